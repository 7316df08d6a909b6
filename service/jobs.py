"""The work behind every endpoint, as plain functions (one code path, two shells).

Each job takes the raw request bytes, parses them with
:func:`kfio.load_request` (numbers stay exact) and calls the same
:mod:`kfio` function the CLI calls.  The HTTP service runs jobs in worker
processes through :func:`run_job`; the CLI may call :data:`JOBS` directly.

Analyzer modules are imported when a job first runs, not when this module
is imported (the workers' forkserver preloads them, see :data:`PRELOAD`).

Examples
--------
>>> body = b'{"system": {"A": [[2]], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": 0.5}}'
>>> status, content, media_type = run_job("analyze", body, Settings(), {}, 30.0)
>>> status, media_type, json.loads(content)["verdict"]
('ok', 'application/json', 'unstable')
"""

from __future__ import annotations

import json
import logging
from typing import Any, Callable, Mapping

from kfio import Budget, Request, load_json, load_request

from .problems import problem_from_exception
from .progress import budget_for
from .settings import Settings

log = logging.getLogger("kfio.service")

#: Modules the workers' forkserver imports once, so that every worker, a
#: replacement too, starts with them loaded.
PRELOAD = (
    "kfio.service.jobs",
    "kfio.service.plots",
    "kfio.riccati_bounds._compute",
    "kfio.simulation._simulate",
    "matplotlib.figure",
    "kfio.service.warmup",  # last: runs one tiny request of each kind (SymPy sub-imports, CVXPY's first solve)
)

JSON = "application/json"
PNG = "image/png"

#: ``(content, media_type)``: what a job hands back to the shell.
JobOutput = tuple[bytes, str]
JobFn = Callable[[bytes, Settings, Budget, Mapping[str, Any]], JobOutput]


def report_json(report: Any) -> JobOutput:
    """The report as the CLI prints it with ``--json`` (same function, same bytes)."""
    from .io import dump_json

    return dump_json(report.to_dict()).encode("utf-8"), JSON


def parse(body: bytes, settings: Settings, command: str | None = None) -> Request:
    """The request, validated with this deployment's limits for ``command``."""
    return load_request(body, settings.limits(command))


def analyze_job(body: bytes, settings: Settings, budget: Budget, params: Mapping[str, Any]) -> JobOutput:
    """``kfio analyze``: the exact verdict (Rohr, Marelli and Fu (2014), Theorem 1).

    The FMO blocks of a plant are kept by the worker (:mod:`kfio._reuse`): the next request
    on the same ``A`` and ``C`` with another channel, ``Q`` or ``R`` skips the eigenstructure.
    """
    from kfio._reuse import reused_fmo_blocks
    from kfio.fit import analyze_at_confidence, load_trace_request
    from kfio.stability import analyze

    request, fits = load_trace_request(body, settings.limits("analyze"))  # a trace channel is fitted first
    report = analyze(request, budget, fmo=reused_fmo_blocks(request.system, budget))
    if "/channel" not in fits:
        return report_json(report)
    block = analyze_at_confidence(request, fits["/channel"], report.verdict, budget)
    return _json_with_fit(report.to_dict(), block)


def _json_with_fit(report: dict[str, Any], block: Any) -> JobOutput:
    """A report with the ``fit`` block of a trace channel (:mod:`kfio.fit`), as the CLI prints it."""
    from .io import dump_json

    return dump_json({**report, "fit": block.to_dict()}).encode("utf-8"), JSON


def fit_job(body: bytes, settings: Settings, budget: Budget, params: Mapping[str, Any]) -> JobOutput:
    """``kfio fit``: a channel model for a packet trace (:func:`kfio.fit.fit_request`)."""
    from kfio import load_json
    from kfio.fit import fit_request

    return report_json(fit_request(load_json(body)))


def bounds_job(body: bytes, settings: Settings, budget: Budget, params: Mapping[str, Any]) -> JobOutput:
    """``kfio bounds``: bounds on the critical probability and on ``E[P]``."""
    from kfio.riccati_bounds import compute_bounds

    return report_json(compute_bounds(parse(body, settings), budget=budget))


def simulate_job(body: bytes, settings: Settings, budget: Budget, params: Mapping[str, Any]) -> JobOutput:
    """``kfio simulate``: Monte Carlo error bands."""
    from kfio.simulation import simulate

    return report_json(simulate(parse(body, settings), budget=budget))


def simulate_long_job(body: bytes, settings: Settings, budget: Budget, params: Mapping[str, Any]) -> JobOutput:
    """``POST /v1/jobs/simulate``: Monte Carlo error bands with the job lane's larger work cap
    (:meth:`kfio.service.settings.Settings.job_simulation_limits`)."""
    from kfio.simulation import simulate

    request = parse(body, settings)
    return report_json(simulate(request, budget=budget, limits=job_simulation_limits(request, settings)))


def job_simulation_limits(request: Request, settings: Settings) -> Any:
    """The job lane's simulation limits, where the request names its ``trajectories``.

    Without it the default count is the synchronous one (it is fitted to the
    synchronous cap), so a job's report equals its synchronous twin's byte for byte.
    """
    from kfio.simulation import DEFAULT_SIMULATION_LIMITS

    sim = request.options.get("simulate")
    if isinstance(sim, Mapping) and "trajectories" in sim:
        return settings.job_simulation_limits()
    return DEFAULT_SIMULATION_LIMITS


def check_job_request(kind: str, body: bytes, settings: Settings) -> None:
    """Validate and size a job's request as its job will, before it is queued (runs in a thread).

    The request is validated (:func:`kfio.load_request`) and, for ``simulate``,
    its options are sized against the job's limits, so a job that would be
    refused is a 422 at once, as on the synchronous endpoint.
    """
    if kind == "fit":
        from kfio.fit import fit_request

        fit_request(load_json(body))
        return
    if kind == "analyze":  # a trace channel is fitted first, as the job will
        from kfio.fit import load_trace_request

        load_trace_request(body, settings.limits(kind))
        return
    request = parse(body, settings, kind)
    if kind == "simulate":
        from kfio.simulation import parse_options

        parse_options(request, job_simulation_limits(request, settings))


def check_job(body: bytes, settings: Settings, budget: Budget, params: Mapping[str, Any]) -> JobOutput:
    """:func:`check_job_request` for the job kind ``params["kind"]``, in a worker of the synchronous lane."""
    check_job_request(str(params.get("kind")), body, settings)
    return b"", JSON


def _plot_job(name: str) -> JobFn:
    def job(body: bytes, settings: Settings, budget: Budget, params: Mapping[str, Any]) -> JobOutput:
        from . import plots

        return getattr(plots, name)(parse(body, settings), budget, params), PNG

    job.__name__ = f"{name}_job"
    job.__doc__ = f"PNG from :func:`kfio.service.plots.{name}`."
    return job


def _sweep_job(body: bytes, settings: Settings, budget: Budget, params: Mapping[str, Any]) -> JobOutput:
    """``POST /v1/sweeps``: :func:`kfio.service.sweep_jobs.sweep_job` (imported when a sweep runs)."""
    from .sweep_jobs import sweep_job

    return sweep_job(body, settings, budget, params)


def _loop_job(body: bytes, settings: Settings, budget: Budget, params: Mapping[str, Any]) -> JobOutput:
    """``kfio loop``: the closed loop's exact verdict, cost and critical probabilities (:mod:`kfio.loop`)."""
    from kfio.fit import load_trace_loop_request, loop_at_confidence
    from kfio.loop import analyze_loop

    request, fits = load_trace_loop_request(body, settings.limits())  # a trace channel is fitted first
    report = analyze_loop(request, budget=budget)
    if not fits:
        return report_json(report)
    (link, found), *_ = fits.items()
    out = report.to_dict()
    return _json_with_fit(out, loop_at_confidence(request, found, link, out, budget))


def _loop_region_job(body: bytes, settings: Settings, budget: Budget, params: Mapping[str, Any]) -> JobOutput:
    """PNG from :func:`kfio.service.loop_plot.loop_region` (a loop request)."""
    from kfio.fit import load_trace_loop_request

    from .loop_plot import loop_region

    return loop_region(load_trace_loop_request(body, settings.limits())[0], budget, params), PNG


def _trace_region_job(body: bytes, settings: Settings, budget: Budget, params: Mapping[str, Any]) -> JobOutput:
    """PNG from :func:`kfio.service.fit_plot.trace_region` (an analyze request with a trace channel)."""
    from .fit_plot import trace_region

    return trace_region(body, settings.limits("analyze"), budget, params), PNG


JOBS: dict[str, JobFn] = {
    "analyze": analyze_job,
    "bounds": bounds_job,
    "simulate": simulate_job,
    "simulate-job": simulate_long_job,
    "check-job": check_job,
    "plot-phase-transition": _plot_job("phase_transition"),
    "plot-region": _plot_job("region"),
    "plot-simulation": _plot_job("simulation"),
    "sweep": _sweep_job,
    "plot-ge-region": _plot_job("ge_region"),
    "loop": _loop_job,
    "plot-loop-region": _loop_region_job,
    "fit": fit_job,
    "plot-trace-region": _trace_region_job,
}


def run_job(name: str, body: bytes, settings: Settings, params: Mapping[str, Any], budget_s: float) -> tuple[Any, ...]:
    """Run one job and never raise (this is what a worker process executes).

    Returns
    -------
    tuple
        ``("ok", content, media_type)``, or ``("problem", fields)`` where
        ``fields`` rebuilds a :class:`kfio.service.problems.Problem`.
    """
    try:
        fn = JOBS[name]  # an unknown name is a bug of the caller: a 500, logged
        budget, params = budget_for(budget_s, params)  # a job's progress file, if it has one
        content, media_type = fn(body, settings, budget, params)
        return ("ok", content, media_type)
    except Exception as exc:  # noqa: BLE001 - every failure becomes a problem document
        problem = problem_from_exception(exc)
        if problem.status >= 500 and problem.kind == "internal":
            log.error("job %s failed on request %s", name, _excerpt(body), exc_info=exc)
        return ("problem", problem.as_plain())


def _excerpt(body: bytes) -> str:
    text = body[:300].decode("utf-8", "replace")
    return json.dumps(text + ("..." if len(body) > 300 else ""))
