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


#: Longest exact text the summary prints beside a decimal; a longer one is named by its degree.
SHORT_EXACT = 24


def _probability(value: float | None, exact: str | None, degree: int | None = None) -> str:
    """``0.5625 (exact: 9/16)``, ``0.453924 (algebraic, degree 2)`` or ``0.453924``: the decimal first.

    The exact text stands beside it when it differs and is short (at most :data:`SHORT_EXACT`
    characters); a longer one is named by the degree of its minimal polynomial when known
    (degree 1: a rational whose text is long).
    """
    text = f"{value:.6g}"
    if exact is None or exact == text:
        return text
    if len(exact) <= SHORT_EXACT:
        return f"{text} (exact: {exact})"
    if degree == 1:
        return f"{text} (rational, {len(exact)} characters exact in --json)"
    return text if degree is None else f"{text} (algebraic, degree {degree})"


def _link_name(critical: dict) -> str:
    """``critical sensor arrival probability``, ``critical recovery rate of sensor gps``, ..."""
    link, parameter = critical["link"], critical["parameter"].rsplit("/", 1)[-1].replace("_", " ")
    if link in ("sensor", "actuator"):
        return (
            f"critical {link} {parameter}"
            if parameter == "arrival probability"
            else f"critical {parameter} of the {link} link"
        )
    return f"critical {parameter} of sensor {link}"


def critical_lines(report: dict) -> list[str]:
    """One line per link (``critical_values`` of the report): its critical value as a decimal, always.

    A link whose stable set is an interval that does not reach 1 (a UDP-like estimator
    assumes the link's arrival rate, so a better link can destabilize the loop) gets that
    interval instead; a link with no stable value says so; a value not computed, the note.
    """
    lines = []
    for c in report.get("critical_values") or []:
        name = _link_name(c)
        poly = c.get("value_minimal_polynomial")
        if c["value"] is not None:
            degree = None if poly is None else len(poly) - 1
            every = " (stable at every value of this link)" if c["value_exact"] == "0" else ""
            lines.append(f"{name}: {_probability(c['value'], c['value_exact'], degree)}{every}")
            continue
        stable = [i for i in c.get("intervals") or [] if i["verdict"] == "stable"]
        if stable:
            spans = " or ".join(f"({_probability(i['from'], None)}, {_probability(i['to'], None)})" for i in stable)
            lines.append(f"{name}: none near 1; stable only for values in {spans}")
        elif c.get("intervals"):
            lines.append(f"{name}: none; no value of this link stabilizes the loop")
        else:
            lines.append(f"{name}: {c['note']}")
    return lines


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
    lines += critical_lines(report)
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
                from kfio.loop import analyze_loop, load_loop_request  # here: `kfio --help` stays fast

                # the same seconds as the watchdog, as `kfio analyze`: work that checks in stops first (a partial report)
                report = analyze_loop(load_loop_request(data), budget=Budget(seconds=seconds)).to_dict()
                emit(dump_json(report) if args.json else summary(report))  # emit: user text made safe
                return exitcodes.BY_VERDICT[report["verdict"]]

            return run_guarded(work)

        return run_supervised(child, seconds, memory_bytes=memory)

    return run_guarded(body)
