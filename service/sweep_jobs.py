"""The worker side of ``POST /v1/sweeps``: one sweep, run inside a job-lane worker process.

The sweep runs serially in the worker (which is already a process of its
own, separate from the synchronous lane), or, when the deployment names a
Dask scheduler (``KFIO_DASK_SCHEDULER``), on that cluster.  Progress (points
done) is reported through the job's budget, which the job store reads when a
client polls.
"""

from __future__ import annotations

import dataclasses
from typing import Any, Mapping

from kfio import Budget
from kfio.errors import BudgetExceeded, InvalidInput

from .problems import Problem, ProblemError
from .settings import Settings

#: The problem type of a deployment whose settings cannot work (``urn:kfio:problem:server-misconfigured``).
MISCONFIGURED = "server-misconfigured"


def misconfigured(setting: str, why: str) -> ProblemError:
    """A 503 that blames the deployment's ``setting``, not the client's request."""
    return ProblemError(
        Problem(
            503,
            MISCONFIGURED,
            "Server misconfigured",
            f"the service's setting {setting} does not work: {why}; this is not a fault of the request",
        )
    )


def dask_missing() -> str | None:
    """Why the Dask engine cannot run here (``None`` if ``distributed`` is importable)."""
    import importlib.util

    if importlib.util.find_spec("distributed") is None:
        return "Dask distributed is not installed (pip install 'kfio[sweep]')"
    return None


#: How long ``kfio serve`` tries to reach ``KFIO_DASK_SCHEDULER`` at start.
DASK_CONNECT_TIMEOUT_S = 5.0


def dask_scheduler_problem(address: str, timeout_s: float | None = None) -> str | None:
    """Why the Dask scheduler at ``address`` cannot be used (``None`` if a client connects to it)."""
    missing = dask_missing()
    if missing is not None:
        return missing
    from distributed import Client

    try:
        client = Client(address, timeout=DASK_CONNECT_TIMEOUT_S if timeout_s is None else timeout_s)
    except (OSError, TimeoutError) as exc:
        return f"cannot reach the Dask scheduler at {address}: {exc}"
    client.close()
    return None


#: The stage name the progress file carries; ``sweep_fraction`` reads the total back from it.
STAGE = "sweep of {total} points"


def sweep_job(body: bytes, settings: Settings, budget: Budget, params: Mapping[str, Any]) -> tuple[bytes, str]:
    """Run the sweep in ``body`` and answer its table as JSON (:meth:`kfio.sweep.SweepResult.to_dict`)."""
    from kfio.sweep import check_points, load_sweep, run_sweep

    from .io import dump_json

    spec = load_sweep(body, settings.max_sweep_points)
    limits = settings.limits()
    # Here, in the worker, under the job's budget and memory limit: a bad point fails the job (422).
    check_points(spec, limits, tick=lambda: budget.tick("validating the sweep's points", 0))
    stage = STAGE.format(total=spec.size)
    last = [0]

    def progress(done: int, total: int) -> None:
        try:
            budget.tick(stage, done - last[0])
        except BudgetExceeded:
            pass  # the sweep's own deadline (below) stops it and gives the rows not reached their error
        last[0] = done

    budget.tick(stage, 0)
    remaining = budget.remaining()
    if remaining is not None:
        spec = dataclasses.replace(spec, time_budget_s=min(spec.time_budget_s or remaining, max(0.01, remaining - 1.0)))
    try:
        result = run_sweep(
            spec,
            engine="dask" if settings.dask_scheduler else "serial",
            scheduler=settings.dask_scheduler,
            progress=progress,
            limits=limits,
            validated=True,
        )
    except InvalidInput as exc:
        # the engine and the scheduler are the deployment's choice here, not the client's
        if settings.dask_scheduler and exc.field in ("/engine", "/scheduler"):
            raise misconfigured("KFIO_DASK_SCHEDULER", exc.rule) from None
        raise
    return dump_json(result.to_dict()).encode("utf-8"), "application/json"


def sweep_fraction(options: Any, progress: Mapping[str, Any]) -> float | None:
    """Share of a sweep's points done, from the worker's progress (``steps`` of ``sweep of N points``)."""
    stage = progress.get("stage")
    done = progress.get("steps")
    if not isinstance(stage, str) or not stage.startswith("sweep of ") or not isinstance(done, int):
        return None
    try:
        total = int(stage.split()[2])
    except (IndexError, ValueError):
        return None
    return None if total <= 0 else min(1.0, done / total)
