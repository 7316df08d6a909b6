"""The exact boundary a sweep's plot can draw, where kfio knows it in closed form.

For a 2-D ``analyze`` sweep whose axes are the arrival probabilities of the two
sensors of a per-sensor Bernoulli channel, the stable region is known exactly
(kfio's per-sensor extension of Rohr, Marelli and Fu (2014), Theorem 1; see
:mod:`kfio.design._regions`): its boundary curve is taken from the report of
the base request.  For a 1-D ``analyze`` sweep of a one-packet Bernoulli
arrival probability, the boundary is the exact critical probability; for a
2-D sweep of a Gilbert-Elliott channel's failure and recovery rates, the
boundary lines of :func:`kfio.design._ge_boundary.boundary_lines` (Rohr,
Marelli and Fu (2014), Theorem 1, on the Gilbert-Elliott family), the same
lines ``kfio analyze --ge-plot`` draws.
"""

from __future__ import annotations

from typing import Any

from ..errors import AnalyzerError
from ..model import json_pointer, parse_request
from ._spec import SweepSpec

#: Sensor probabilities on the exact boundary curve of a 2-D loop sweep (each vertex exact).
LOOP_CURVE_POINTS = 40
_SENSOR, _ACTUATOR = "/channel/arrival_probability", "/actuator_channel/arrival_probability"


def exact_boundary(spec: SweepSpec) -> dict[str, Any] | None:
    """``{"kind": "curve", "x": [...], "y": [...], "axes": (name_x, name_y)}`` or
    ``{"kind": "threshold", "value": float, "exact": str, "axis": name}``, else ``None``."""
    if spec.requests is not None or spec.base is None:
        return None
    if spec.command == "loop":
        return _loop_boundary(spec)
    if spec.command != "analyze":
        return None
    channel = spec.base.get("channel", {})
    pointers = [a.pointer for a in spec.axes]
    try:
        if (
            len(spec.axes) == 1
            and pointers[0] == "/channel/arrival_probability"
            and channel.get("model") == "bernoulli"
        ):
            from ..stability import analyze

            rep = analyze(parse_request(spec.base)).to_dict()
            if rep.get("critical_arrival_probability") is None:
                return None
            return {
                "kind": "threshold",
                "axis": spec.axes[0].name,
                "value": rep["critical_arrival_probability"],
                "exact": rep["critical_arrival_probability_exact"],
            }
        if len(spec.axes) == 2 and channel.get("model") == "gilbert_elliott":
            rate_of = {"/channel/failure_rate": "failure_rate", "/channel/recovery_rate": "recovery_rate"}
            if sorted(pointers) != sorted(rate_of):
                return None
            from ..stability import GeStructure, analyze, boundary_lines

            region = analyze(parse_request(spec.base)).gilbert_elliott
            if region is None:  # skipped unasked (a long period): ask for it, with the request's own budget
                base = {**spec.base, "options": {**spec.base.get("options", {}), "analyze": {"ge_grid": 1}}}
                region = analyze(parse_request(base)).gilbert_elliott
            if region is None:
                return None
            x: list[float | None] = []
            y: list[float | None] = []
            for line in boundary_lines(GeStructure(region.patterns)):
                coords = {"recovery_rate": line.q, "failure_rate": line.p}
                close = 1 if line.closed else 0
                x.extend([*coords[rate_of[pointers[0]]], *coords[rate_of[pointers[0]]][:close], None])
                y.extend([*coords[rate_of[pointers[1]]], *coords[rate_of[pointers[1]]][:close], None])
            return {"kind": "curve", "axes": (spec.axes[0].name, spec.axes[1].name), "x": x, "y": y} if x else None
        if len(spec.axes) == 2 and channel.get("model") == "per_sensor":
            names = list(channel.get("channels", {}))
            wanted = [json_pointer(("channel", "channels", n, "arrival_probability")) for n in names]
            if len(names) != 2 or sorted(pointers) != sorted(wanted):
                return None
            from ..stability import analyze

            rep = analyze(parse_request(spec.base)).to_dict()
            boundary = (rep.get("regions") or {}).get("boundary")
            if not boundary or "samples" not in boundary:
                return None
            x, y = list(boundary["samples"]["lambda_1"]), list(boundary["samples"]["lambda_2"])
            first = next((k for k, v in enumerate(y) if v is not None), None)
            lam1_min = (boundary.get("envelope") or {}).get("lambda_1_min")
            if first is not None and lam1_min is not None:
                # the region is lambda_1 > lambda_1_min and lambda_2 > h(lambda_1): close it with the vertical edge
                x[first:first] = [lam1_min, lam1_min]
                y[first:first] = [1.0, y[first]]
            if pointers != wanted:  # the sweep's first axis is the second sensor
                x, y = y, x
            return {"kind": "curve", "axes": (spec.axes[0].name, spec.axes[1].name), "x": x, "y": y}
    except AnalyzerError:  # e.g. the base request breaks Assumption 1: the plot draws the rows alone
        return None
    return None


def _loop_boundary(spec: SweepSpec) -> dict[str, Any] | None:
    """The exact boundary of a loop sweep over its links' Bernoulli arrival probabilities.

    One axis: the base loop's exact critical arrival probability of that link, the other link
    as in the base (Costa, Fragoso and Marques 2005, Thm 3.9; :func:`kfio.loop.analyze_loop`).
    Two axes (sensor and actuator): the points ``(lam, nu_c(lam))`` of :func:`kfio.loop.region`,
    each exactly on the curve where the loop changes verdict, and where the curve leaves the top
    edge ``nu = 1`` (the critical sensor probability with every actuator packet arriving).
    """
    from .._budget import Budget
    from ..loop import analyze_loop, parse_loop_request, region

    pointers = [a.pointer for a in spec.axes]
    try:
        request = parse_loop_request(spec.base)
        if len(spec.axes) == 1 and pointers[0] in (_SENSOR, _ACTUATOR):
            link = "sensor" if pointers[0] == _SENSOR else "actuator"
            report = analyze_loop(request, budget=Budget(seconds=spec.point_budget_s)).to_dict()
            value = report.get(f"critical_{link}_arrival_probability")
            if value is None:
                return None
            return {
                "kind": "threshold",
                "axis": spec.axes[0].name,
                "value": value,
                "exact": report.get(f"critical_{link}_arrival_probability_exact"),
            }
        if len(spec.axes) == 2 and sorted(pointers) == sorted([_SENSOR, _ACTUATOR]):
            found = region(request, LOOP_CURVE_POINTS, Budget(seconds=spec.point_budget_s))
            if found is None:
                return None
            rows = found.boundary
            x: list[float | None] = [r.sensor_arrival_probability for r in rows]
            y = [r.critical_actuator_arrival_probability for r in rows]
            first = next((k for k, v in enumerate(y) if v is not None), None)
            if first is not None and first > 0:
                # where the curve leaves the top edge: the critical sensor probability with every actuator packet
                tree = {**spec.base, "actuator_channel": {"model": "bernoulli", "arrival_probability": 1}}
                top = analyze_loop(parse_loop_request(tree), budget=Budget(seconds=spec.point_budget_s)).to_dict()
                lam_top = top.get("critical_sensor_arrival_probability")
                if lam_top is not None and lam_top <= x[first]:
                    x[first:first] = [lam_top]
                    y[first:first] = [1.0]
            if pointers[0] == _ACTUATOR:  # the sweep's first axis is the actuator's
                x, y = y, x
            return {"kind": "curve", "axes": (spec.axes[0].name, spec.axes[1].name), "x": x, "y": y}
    except AnalyzerError:  # a base the loop analysis refuses: the plot draws the rows alone
        return None
    return None
