"""``kfio.sweep(...)``: the Python door of ``kfio sweep``, typed, with the conventions of :func:`kfio.analyze`.

The spec is what a sweep file holds, in any of its forms (the file's path,
its parsed tree, or a :class:`~kfio.sweep.SweepSpec`); the run is
:func:`~kfio.sweep.run_sweep`'s, so the rows are those ``kfio sweep --out
x.jsonl`` writes for the same file.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, Literal

from ..errors import InvalidInput
from ..model import budget_seconds, option_field, positive_ints, python_tree, read_limited
from ._engine import Progress, SweepResult, run_sweep
from ._spec import SweepSpec, load_sweep, parse_sweep

if TYPE_CHECKING:
    from .._typing import BudgetLike

#: The largest sweep budget in seconds, as ``options.time_budget_s`` of a sweep file.
MAX_SWEEP_BUDGET_S = int(option_field("sweep", "time_budget_s").maximum or 0)

#: The largest sweep file read from a path (larger than one request: JSON Lines of plant variants).
MAX_SWEEP_FILE_BYTES = 64 << 20

ENGINES = ("auto", "dask", "serial")


def sweep_spec(spec: SweepSpec | Mapping[str, Any] | str | os.PathLike[str]) -> SweepSpec:
    """The validated :class:`SweepSpec` of a sweep file's path, its parsed tree, or a spec (unchanged)."""
    if isinstance(spec, SweepSpec):
        return spec
    if isinstance(spec, Mapping):
        return parse_sweep(python_tree(dict(spec)))
    if isinstance(spec, (str, os.PathLike)):
        too_large = f"the sweep file is larger than {MAX_SWEEP_FILE_BYTES >> 20} MiB"
        return load_sweep(
            read_limited(spec, MAX_SWEEP_FILE_BYTES, "spec", too_large, name="the sweep file ", stdin=False)
        )
    raise InvalidInput(
        "spec", f"expected a sweep file's path, its parsed JSON object or a SweepSpec; got a {type(spec).__name__}"
    )


def sweep(
    spec: SweepSpec | Mapping[str, Any] | str | os.PathLike[str],
    *,
    engine: Literal["auto", "dask", "serial"] = "auto",
    scheduler: str | None = None,
    workers: int | None = None,
    chunk_size: int | None = None,
    progress: Progress | None = None,
    budget: BudgetLike | None = None,
) -> SweepResult:
    """Run one command over many points: a base request and axes (grid or zip), or a list of requests.

    Every point is validated before any work starts; FMO blocks and verdicts
    are shared between points of one plant; the points run in this process
    or on Dask (see ``docs/sweeps.md``).

    Parameters
    ----------
    spec:
        A sweep file's path (JSON, or JSON Lines of whole requests), its
        parsed JSON object (``{"command": ..., "base": ..., "axes": [...]}``)
        or a :class:`kfio.sweep.SweepSpec`.
    engine:
        ``"auto"`` (chosen by the work), ``"dask"`` (an embedded LocalCluster,
        or ``scheduler``) or ``"serial"`` (this process, no Dask needed).
    scheduler:
        Address of a running Dask scheduler, e.g. ``"tcp://127.0.0.1:8786"``.
    workers, chunk_size:
        Worker processes of the embedded cluster (default: cores) and points
        per task (default: balanced).
    progress:
        Called with ``(points done, points)`` as points finish.
    budget:
        The whole sweep's wall-clock budget: seconds (in ``[0.01, 86400]``, as
        ``options.time_budget_s`` of the file, which it replaces) or a
        :class:`kfio.Budget` (what remains of its clock).  Points not done
        in time get ``budget-exceeded`` error rows and ``result.stopped``
        says so; the sweep itself does not raise.

    Returns
    -------
    SweepResult
        ``rows`` in index order, each with ``coordinates`` and ``fields``
        (``row.exact_of("critical_arrival_probability")``); ``to_dict()`` is
        the JSON of ``POST /v1/sweep``.

    Raises
    ------
    InvalidInput
        A bad argument, named (``engine``, ``workers``, ``budget``), or a bad
        sweep file, naming its field (``/axes/0/num``).

    Examples
    --------
    >>> import kfio
    >>> result = kfio.sweep({"command": "analyze",
    ...     "base": {"system": {"A": [[2]], "C": [[1]]},
    ...              "channel": {"model": "bernoulli", "arrival_probability": "1/2"}},
    ...     "axes": [{"pointer": "/channel/arrival_probability", "from": "1/2", "to": "9/10", "num": 3}]},
    ...     engine="serial", budget=60)
    >>> [(row.fields["verdict"], row.exact_of("critical_arrival_probability")) for row in result.rows]
    [('unstable', Fraction(3, 4)), ('unstable', Fraction(3, 4)), ('stable', Fraction(3, 4))]
    """
    if engine not in ENGINES:
        raise InvalidInput("engine", f"expected one of {', '.join(map(repr, ENGINES))}; got {engine!r}")
    positive_ints(workers=workers, chunk_size=chunk_size)
    if scheduler is not None and not isinstance(scheduler, str):
        raise InvalidInput("scheduler", f"expected an address such as 'tcp://127.0.0.1:8786'; got {scheduler!r}")
    seconds = budget_seconds(budget, MAX_SWEEP_BUDGET_S)
    parsed = sweep_spec(spec)
    if seconds is not None:
        parsed = dataclasses.replace(parsed, time_budget_s=seconds)
    return run_sweep(
        parsed, engine=engine, scheduler=scheduler, workers=workers, chunk_size=chunk_size, progress=progress
    )


__all__ = ["sweep", "sweep_spec"]
