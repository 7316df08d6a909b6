"""``kfio loop FILE [--json]``: the exact verdict, cost and critical link reliabilities of a closed loop.

The loop request (``docs/loop.md``) adds ``system.B``, ``actuator_channel``,
``controller`` and ``options.loop`` to a request file.  Exit codes as
``kfio analyze``: 0 stable, 1 unstable, 3 boundary, 2 invalid input, 4 budget
exceeded, 5 numerical failure.
"""

from __future__ import annotations

import argparse

from .. import exitcodes
from ..io import (
    DEFAULT_TIME_BUDGET_S,
    add_request_arguments,
    dump_json,
    emit,
    memory_limit,
    read_request_text,
    request_budget,
    run_guarded,
)
from ..watchdog import run_supervised
from .fit import TraceLoader, add_trace_arguments


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "loop",
        help="closed loop over lossy sensor and actuator links: exact verdict, cost, critical probabilities",
        description="Decide exactly whether a loop closed over lossy sensor and actuator links is mean-square "
        "stable (Costa, Fragoso and Marques 2005, Thm 3.9), with its stationary cost and the critical arrival "
        "probability of each link. Exit 0 stable, 1 unstable, 3 boundary, 2 invalid input, 4 budget exceeded, "
        "5 numerical failure.",
    )
    add_request_arguments(p)
    add_trace_arguments(p)
    p.set_defaults(func=_run, quick_exit=True)


def _probability(value: float | None, exact: str | None) -> str:
    """``0.5625`` or ``0.372842 (exact: 15625.../41908...)``: the decimal first, the exact text beside it when it differs."""
    text = f"{value:.6g}"
    return text if exact is None or exact == text else f"{text} (exact: {exact})"


def summary(report: dict) -> str:
    """A few lines for people: the exact verdict first, then the cost, the critical probabilities and the bounds.

    Every number is read from ``report`` (the JSON of ``--json``); a test compares them.
    """
    verdict = report["verdict"]
    lines = [
        f"verdict: {verdict.upper()}  (exact mean-square verdict, Costa, Fragoso and Marques 2005, Thm 3.9; "
        f"spectral radius {report['spectral_radius']:.6g})"
    ]
    cost = report["cost"]
    lines.append(f"stationary cost of these gains: {'unbounded' if cost is None else f'{cost:.6g}'}")
    for key in ("sensor", "actuator"):
        exact = report[f"critical_{key}_arrival_probability_exact"]
        if exact is not None:
            value = _probability(report[f"critical_{key}_arrival_probability"], exact)
            lines.append(f"critical {key} arrival probability: {value}")
    statement = report["estimator_alone"]["statement"]
    if statement:
        lines.append(f"estimator alone: {statement}")
    lqg = report.get("lqg") or {}
    nu_c = lqg.get("nu_c")
    if nu_c:
        if nu_c.get("is_exact"):
            lines.append(
                f"control equation converges iff actuator arrival probability > {_probability(nu_c['lower'], nu_c['exact'])}"
            )
        elif nu_c.get("upper") is not None:
            lines.append(
                f"control equation's critical actuator probability: in [{nu_c['lower']:.6g}, {nu_c['upper']:.6g}]"
            )
    bounds = lqg.get("cost_bounds") or {}
    if bounds.get("lower") is not None and bounds.get("upper") is not None:
        lines.append(
            f"optimal TCP-like LQG cost: between {bounds['lower']:.6g} and {bounds['upper']:.6g} (bounds, "
            "Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V)"
        )
    udp = report.get("udp_region_bounds") or {}
    outer = udp.get("outer") or {}
    if outer.get("sensor_arrival_probability_above") is not None:
        parts = [
            f"sensor > {_probability(outer['sensor_arrival_probability_above'], outer['sensor_arrival_probability_above_exact'])}"
        ]
        if outer.get("actuator_arrival_probability_above") is not None:
            parts.append(
                f"actuator > {_probability(outer['actuator_arrival_probability_above'], outer['actuator_arrival_probability_above_exact'])}"
            )
        lines.append(f"optimal UDP-like controller needs (bound): {', '.join(parts)}")
    if report.get("partial"):
        lines += [n for n in report["notes"] if n.startswith("partial:")]
    return "\n".join(lines)


def _run(args: argparse.Namespace) -> int:
    def body() -> int:
        if args.time_budget is not None and not 0.01 <= args.time_budget <= 86400:
            from kfio.errors import InvalidInput

            raise InvalidInput("--time-budget", "must be in [0.01, 86400] seconds")
        memory = memory_limit(args)
        data = read_request_text(args.file)
        seconds = args.time_budget or request_budget(data) or DEFAULT_TIME_BUDGET_S

        def child() -> int:
            def work() -> int:
                from kfio import Budget
                from kfio.loop import analyze_loop  # here: `kfio --help` stays fast

                traces = TraceLoader(args)
                request = traces.apply(traces.load_loop(data))
                # the same seconds as the watchdog, as `kfio analyze`: work that checks in stops first (a partial report)
                budget = Budget(seconds=seconds)
                report = analyze_loop(request, budget=budget).to_dict()
                lines = []
                if traces.fit is not None:  # the verdict of the whole confidence region beside the estimate's
                    from kfio.fit import loop_at_confidence

                    block = loop_at_confidence(request, traces.fit, traces.link, report, budget)
                    report = {**report, "fit": block.to_dict()}
                    lines = block.summary_lines()
                emit(
                    dump_json(report) if args.json else "\n".join([summary(report), *lines])
                )  # emit: user text made safe
                return exitcodes.BY_VERDICT[report["verdict"]]

            return run_guarded(work)

        return run_supervised(child, seconds, memory_bytes=memory)

    return run_guarded(body)
