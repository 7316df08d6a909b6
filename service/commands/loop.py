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
    p.set_defaults(func=_run, quick_exit=True)


def summary(report: dict) -> str:
    """A few lines for people: the verdict first, then the cost and the critical probabilities."""
    lines = [f"verdict: {report['verdict']} (spectral radius {report['spectral_radius']:.6g})"]
    cost = report["cost"]
    lines.append(f"stationary cost: {'unbounded' if cost is None else f'{cost:.6g}'}")
    for key, name in (("sensor", "sensor"), ("actuator", "actuator")):
        v = report[f"critical_{key}_arrival_probability_exact"]
        if v is not None:
            lines.append(f"critical {name} arrival probability: {v}")
    statement = report["estimator_alone"]["statement"]
    if statement:
        lines.append(f"estimator alone: {statement}")
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
                from kfio.loop import analyze_loop, load_loop_request  # here: `kfio --help` stays fast

                # the same seconds as the watchdog, as `kfio analyze`: work that checks in stops first (a partial report)
                report = analyze_loop(load_loop_request(data), budget=Budget(seconds=seconds)).to_dict()
                emit(dump_json(report) if args.json else summary(report))  # emit: user text made safe
                return exitcodes.BY_VERDICT[report["verdict"]]

            return run_guarded(work)

        return run_supervised(child, seconds, memory_bytes=memory)

    return run_guarded(body)
