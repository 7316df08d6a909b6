"""``kfio.check(...)``: the Python door of ``kfio check``, typed, with the conventions of :func:`kfio.analyze`.

The spec is what a check file holds, in any of its forms (the file's path,
its parsed tree with the directory its paths are relative to, or a
:class:`~kfio.check.CheckSpec`); the paths it names are confined as those of
the file (:func:`~kfio.check.parse_check`), and the run is
:func:`~kfio.check.run_check`'s, so the outcomes are those ``kfio check
--json`` prints for the same file.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import InvalidInput
from ..model import MAX_RUN_BUDGET_S, budget_seconds, positive_ints
from ._run import CheckResult, run_check
from ._spec import CheckSpec, load_check, parse_check

if TYPE_CHECKING:
    from .._typing import BudgetLike


def check(
    spec: CheckSpec | Mapping[str, Any] | str | os.PathLike[str],
    *,
    base: str | os.PathLike[str] | None = None,
    allow_outside: Iterable[str | os.PathLike[str]] = (),
    workers: int | None = None,
    memory_bytes: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    budget: BudgetLike | None = None,
) -> CheckResult:
    """Judge plants and channels against the requirements of a check file.

    Each entry names a plant and a channel (files, or a loop or a trace) and
    requirements on them: the exact verdict, a margin on the worst rate, the
    critical arrival probability, a certified bound on ``trace(V_bar)``, the
    tail exponent, an outage probability, a loop's cost and link
    reliabilities (``docs/check.md``).  Each requirement is judged on the
    report of ``analyze``, ``bounds``, ``simulate`` or ``loop`` for its entry.

    Parameters
    ----------
    spec:
        A check file's path (JSON, or TOML by its suffix), its parsed object
        (``{"checks": [...], "options": {...}}``) or a :class:`kfio.check.CheckSpec`.
    base:
        With a parsed object: the directory its paths are relative to
        (default: the current directory).  A path's base is its file's directory.
    allow_outside:
        Directories whose files the spec may name too; by default it may name
        only regular files under its base, symlinks followed.
    workers:
        Worker processes (default: cores, at most one per run); ``1`` runs in
        this process, with the cooperative budgets only.
    memory_bytes:
        Address-space limit of each worker process.
    progress:
        Called with ``(runs done, runs)`` as runs finish.
    budget:
        The whole check's wall-clock budget: seconds (in ``[0.01, 86400]``,
        replacing ``options.time_budget_s`` of the file, default 600) or a
        :class:`kfio.Budget` (what remains of its clock).  Requirements whose
        run did not finish in time are outcomes with ``error_kind
        "budget-exceeded"`` and ``result.status == "budget"``; the check itself
        does not raise.

    Returns
    -------
    CheckResult
        ``status`` (``pass``, ``fail`` or ``budget``), ``outcomes`` in the
        file's order (``outcome.exact_of("measured")``); ``to_dict()`` is the
        JSON of ``kfio check --json``.

    Raises
    ------
    InvalidInput
        A bad argument, named (``base``, ``workers``, ``budget``), or a bad
        check file, naming its field (``/checks/0/requirements/margin``).

    Examples
    --------
    >>> import json, pathlib, tempfile, kfio
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "plant.json").write_text(json.dumps({"system": {"A": [[-1.25]], "C": [[1]]}}))
    >>> _ = (d / "radio.json").write_text(json.dumps({"model": "bernoulli", "arrival_probability": "1/2"}))
    >>> result = kfio.check({"checks": [{"name": "scalar", "plant": "plant.json", "channel": "radio.json",
    ...     "requirements": {"critical_arrival_probability_at_most": "2/5"}}]}, base=d, workers=1, budget=60)
    >>> result.status, result.outcomes[0].exact_of("measured"), result.outcomes[0].exact_of("required")
    ('pass', Fraction(9, 25), Fraction(2, 5))
    """
    positive_ints(workers=workers, memory_bytes=memory_bytes)
    seconds = budget_seconds(budget, MAX_RUN_BUDGET_S)
    dirs = _directories(allow_outside)
    parsed = _spec(spec, base, dirs)
    return run_check(parsed, workers=workers, time_budget_s=seconds, memory_bytes=memory_bytes, progress=progress)


def _directories(allow_outside: Any) -> list[Path]:
    if isinstance(allow_outside, (str, os.PathLike)):
        allow_outside = [allow_outside]
    try:
        dirs = list(allow_outside)
    except TypeError:
        raise InvalidInput("allow_outside", "expected a list of directories") from None
    for d in dirs:
        if not isinstance(d, (str, os.PathLike)) or not os.path.isdir(d):
            raise InvalidInput("allow_outside", f"{d!r} is not a directory")
    return [Path(d) for d in dirs]


def _spec(spec: Any, base: Any, dirs: list[Path]) -> CheckSpec:
    if isinstance(spec, CheckSpec):
        if base is not None or dirs:
            name = "base" if base is not None else "allow_outside"
            raise InvalidInput(name, "a parsed CheckSpec has its paths resolved already: pass the file or its object")
        return spec
    if isinstance(spec, Mapping):
        where = Path.cwd() if base is None else base
        if not isinstance(where, (str, os.PathLike)) or not os.path.isdir(where):
            raise InvalidInput("base", f"{where!r} is not a directory")
        return parse_check(dict(spec), Path(where), "<check>", dirs)
    if isinstance(spec, (str, os.PathLike)):
        if base is not None:
            raise InvalidInput("base", "a check file's paths are relative to its own directory: base is for an object")
        return load_check(Path(spec), dirs)
    raise InvalidInput(
        "spec", f"expected a check file's path, its parsed object or a CheckSpec; got a {type(spec).__name__}"
    )


__all__ = ["check"]
