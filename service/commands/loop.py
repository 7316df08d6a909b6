"""``kfio loop FILE [--json]``: the exact verdict, cost and critical link reliabilities of a closed loop.

The loop request (``docs/loop.md``) adds ``system.B``, ``actuator_channel``,
``controller`` and ``options.loop`` to a request file.  Exit codes as
``kfio analyze``: 0 stable, 1 unstable, 3 boundary, 2 invalid input, 4 budget
exceeded, 5 numerical failure.
"""

from __future__ import annotations

import argparse
from typing import Any

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
    time_budget,
)
from ..watchdog import run_supervised
from .fit import TraceLoader, add_trace_arguments


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
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


def _probability(value: float | None, exact: str | None, degree: int | None = None) -> str:
    """``0.5625 = 9/16``, ``0.453924 (algebraic, degree 2)`` or ``0.453924``: kfio's one number format.

    :func:`kfio._numbers.summary_number` decides from the exact text; a long algebraic value whose
    minimal polynomial's degree the report knows is named by that degree (and, when its text
    carries the digits of float data, says so too), as in ``kfio analyze``'s summary.
    """
    from kfio._numbers import summary_number

    return summary_number(exact, value, degree=degree)


def _link_name(critical: dict[str, Any]) -> str:
    """``critical sensor arrival probability``, ``critical recovery rate of sensor gps``, ..."""
    link, parameter = critical["link"], critical["parameter"].rsplit("/", 1)[-1].replace("_", " ")
    if link in ("sensor", "actuator"):
        return (
            f"critical {link} {parameter}"
            if parameter == "arrival probability"
            else f"critical {parameter} of the {link} link"
        )
    return f"critical {parameter} of sensor {link}"


def critical_lines(report: dict[str, Any]) -> list[str]:
    """One line per link (``critical_values`` of the report): its critical value as a decimal, always.

    A link whose stable set is an interval that does not reach 1 (a UDP-like estimator
    assumes the link's arrival rate, so a better link can destabilize the loop) gets that
    interval instead; a link with no stable value says so; a loop too large for the exact value,
    the certified bracket; a value not computed, the note.
    """
    lines = []
    for c in report.get("critical_values") or []:
        name = _link_name(c)
        if c["value"] is not None:
            degree = c.get("value_minimal_polynomial_degree")  # known also when the coefficients are capped
            every = " (stable at every value of this link)" if c["value_exact"] == "0" else ""
            lines.append(f"{name}: {_probability(c['value'], c['value_exact'], degree)}{every}")
            continue
        bracket = c.get("value_bracket")
        stable = [i for i in c.get("intervals") or [] if i["verdict"] == "stable"]
        if bracket:  # an operator too large for the exact value: both ends proved (the note in --json says how)
            lo, hi = (_probability(x, None) for x in bracket)
            lines.append(f"{name}: in [{lo}, {hi}] (certified bracket: proved unstable at {lo}, stable at {hi})")
        elif stable:
            spans = " or ".join(f"({_probability(i['from'], None)}, {_probability(i['to'], None)})" for i in stable)
            lines.append(f"{name}: none near 1; stable only for values in {spans}")
        elif c.get("intervals"):
            lines.append(f"{name}: none; no value of this link stabilizes the loop")
        else:
            lines.append(f"{name}: {c['note']}")
    return lines


def summary(report: dict[str, Any]) -> str:
    """A few lines for people: the exact verdict first, then the cost, the critical probabilities and the bounds.

    Every number is read from ``report`` (the JSON of ``--json``); a test compares them.
    """
    verdict = report["verdict"]
    lqg = report.get("lqg") or {}
    if lqg and not lqg["stationary_gains"]["exist"]:
        return _lqg_without_gains(report)
    lines = [
        f"verdict: {verdict.upper()}  ({'exact' if report['exact'] else 'certified'} mean-square verdict, "
        "Costa, Fragoso and Marques 2005, Thm 3.9; "
        f"spectral radius {report['spectral_radius']:.6g})"
    ]
    cost = report["cost"]
    lines.append(f"stationary cost of these gains: {'unbounded' if cost is None else f'{cost:.6g}'}")
    lines += critical_lines(report)
    statement = report["estimator_alone"]["statement"]
    if statement:
        lines.append(f"estimator alone: {statement}")
    if lqg:
        lines += _lqg_lines(report)
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


def _optimal_actuator(optimal: dict[str, Any]) -> str:
    """The optimal TCP-like controller's critical actuator probability: exact, bracketed, or none."""
    crit = optimal["critical_actuator"]
    if optimal["critical_actuator_arrival_probability"] is not None:
        value = optimal["critical_actuator_arrival_probability"]
        return "> " + _probability(value, optimal["critical_actuator_arrival_probability_exact"])
    if crit["lower"] is not None and crit["upper"] is not None:
        return f"> a value in [{crit['lower']:.6g}, {crit['upper']:.6g}]"
    return "no probability suffices" if not crit["stabilizable"] else "unknown"


def _optimal_sensor(optimal: dict[str, Any]) -> str:
    value = optimal["critical_sensor_arrival_probability"]
    if value is None:
        return "no probability suffices"
    return "> " + _probability(value, optimal["critical_sensor_arrival_probability_exact"])


def _lqg_lines(report: dict[str, Any]) -> list[str]:
    """LQG: the optimal TCP-like controller's critical values beside those of the stationary gains, and its cost bounds."""
    lqg = report["lqg"]
    optimal = lqg["optimal"]
    form = lqg["stationary_gains"]["form"]

    def stationary(key: str) -> str:
        value = report[f"critical_{key}_arrival_probability"]
        return "n/a" if value is None else f"{value:.6g}"

    lines = [
        f"LQG, TCP-like (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V), critical "
        f"probabilities: optimal | these gains ({form} form)",
        f"  sensor:   optimal {_optimal_sensor(optimal)} | stationary {stationary('sensor')}",
        f"  actuator: optimal {_optimal_actuator(optimal)} | stationary {stationary('actuator')}",
    ]
    bounds = optimal["cost_bounds"]
    if bounds.get("lower") is not None and bounds.get("upper") is not None:
        lines.append(
            f"optimal TCP-like LQG cost: between {bounds['lower']:.6g} and {bounds['upper']:.6g} (bounds, "
            "Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V)"
        )
    return lines


def _lqg_without_gains(report: dict[str, Any]) -> str:
    """LQG below the optimal critical values: the verdict, why, and what the optimal controller needs."""
    optimal = report["lqg"]["optimal"]
    lines = [
        f"verdict: {report['verdict'].upper()}  (no TCP-like controller has a bounded cost here; Schenato, Sinopoli, "
        "Franceschetti, Poolla and Sastry 2007, Sec. V)",
        "stationary cost: unbounded (no stationary LQG gains exist)",
    ]
    lines += [f"why: {reason}" for reason in optimal["reasons"]]
    lines.append(
        f"the optimal TCP-like LQG needs: sensor {_optimal_sensor(optimal)}; actuator {_optimal_actuator(optimal)}"
    )
    return "\n".join(lines)


def _run(args: argparse.Namespace) -> int:
    def body() -> int:
        flag = time_budget(args)
        memory = memory_limit(args)
        data = read_request_text(args.file)
        seconds = flag or request_budget(data) or DEFAULT_TIME_BUDGET_S

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
