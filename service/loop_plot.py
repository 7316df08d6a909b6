"""PNG of a closed loop: its stable region in the plane of the two links, and its cost along each link.

Everything drawn comes from :mod:`kfio.loop`, the functions that fill the
loop report: each cell of the map is the exact verdict
(:func:`kfio.loop._verdict.decide`, Costa, Fragoso and Marques 2005,
Thm 3.9) at its centre; the boundary line (Bernoulli x Bernoulli) is the
report's ``region.boundary`` (:func:`kfio.loop._region.region`); the cost
curves are the exact stationary cost (:func:`kfio.loop._cost.stationary_cost`)
with one link varied and the other held at the request's value, and the
dashed lines are the report's critical values.  This is the picture of
Schenato, Sinopoli, Franceschetti, Poolla and Sastry (2007, Sec. V) for the
given gains.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Callable, Mapping

import numpy as np

from kfio import Budget, InvalidInput
from kfio.model import MarkovChannel

from .plots import figure_headline, legend_beside, new_figure, png_bytes

#: Gids of the drawn artists (tests read them back).
BOUNDARY_GID = "loop-boundary"
SENSOR_COST_GID = "loop-cost-sensor"
ACTUATOR_COST_GID = "loop-cost-actuator"
THEOREM_TEXT = "exact, Costa, Fragoso and Marques 2005, Thm 3.9"

_CODE = {"unstable": -1.0, "boundary": 0.0, "stable": 1.0}


@dataclass(frozen=True)
class _Axis:
    """One link's parameter: its pointer, the channel at a value, and the request's value."""

    label: str
    pointer: str
    parameter: str
    at: Callable[[Fraction], MarkovChannel]
    value: Fraction


def _axes(req: Any) -> tuple[_Axis, _Axis]:
    from kfio.loop import parameter_of, sensor_links

    links = sensor_links(req)
    if len(links) != 1:
        raise InvalidInput("/channel/model", "the loop region plot needs one sensor packet (one sensor link)")
    lk = links[0][0]
    out = []
    for label, pointer, ch in (("sensor", lk.pointer, lk.channel), ("actuator", "/actuator_channel", req.actuator)):
        par = parameter_of(pointer, ch)
        if par is None:
            where = "/channel/model" if label == "sensor" else "/actuator_channel/model"
            raise InvalidInput(where, f"the loop region plot needs a bernoulli or gilbert_elliott {label} link")
        key = "arrival_probability" if ch.model == "bernoulli" else "recovery_rate"
        out.append(_Axis(label, pointer, par[0], par[1], Fraction(ch.params[key])))
    return out[0], out[1]


def _short(parameter: str) -> str:
    return parameter.rsplit("/", 1)[-1].replace("_", " ")


def loop_region_data(req: Any, points: int) -> dict[str, Any]:
    """The values drawn by :func:`loop_region_figure`, all from :mod:`kfio.loop` (module docstring)."""
    from kfio.loop import analyze_loop, decide, loop_mjls, region, stationary_cost

    if not req.K:  # LQG below the optimal TCP-like critical values: the verdict is kfio loop's, there is no loop
        raise InvalidInput(
            "/controller/lqg",
            "no stationary LQG gains exist at this request's link probabilities (below the optimal TCP-like "
            "critical values), so there is no loop to draw; kfio loop gives the verdict and the critical values",
        )
    sx, ax = _axes(req)
    report = analyze_loop(req).to_dict()
    centres = [Fraction(2 * i + 1, 2 * points) for i in range(points)]
    labels = [
        [decide(loop_mjls(req, {sx.pointer: sx.at(x), ax.pointer: ax.at(y)})).verdict for y in centres] for x in centres
    ]
    found = region(req, points)  # None unless both links are Bernoulli
    boundary = None if found is None else found.to_dict()
    along = [Fraction(k, 4 * points) for k in range(1, 4 * points)]
    costs: dict[str, list[float | None]] = {}
    for axis in (sx, ax):
        row: list[float | None] = []
        for x in along:
            sys = loop_mjls(req, {axis.pointer: axis.at(x)})
            dec = decide(sys)
            row.append(dec.cost if dec.moments is None else float(stationary_cost(sys, dec.moments)))
        costs[axis.label] = row
    return {
        "report": report,
        "sensor": sx,
        "actuator": ax,
        "centres": [float(c) for c in centres],
        "labels": labels,
        "boundary": boundary,
        "along": [float(x) for x in along],
        "costs": costs,
    }


def loop_region(req: Any, budget: Budget, params: Mapping[str, Any]) -> bytes:
    """``POST /v1/plots/loop-region``: the PNG of :func:`loop_region_figure` for a loop request."""
    return png_bytes(loop_region_figure(loop_region_data(req, int(params.get("points", 21)))))


def _critical(report: Mapping[str, Any], label: str) -> tuple[float | None, str | None]:
    key = f"critical_{label}_arrival_probability"
    if report.get(key) is not None:
        return report[key], report.get(f"{key}_exact")
    for c in report.get("critical_values") or []:
        if c["link"] == label or (label == "sensor" and c["link"] != "actuator"):
            return c["value"], c["value_exact"]
    return None, None


def _num(value: float | None, exact: str | None) -> str:
    if value is None:
        return "none"
    return exact if exact is not None and len(exact) <= 12 else f"{value:.4g}"


def _missing(report: Mapping[str, Any], label: str) -> str:
    """Why a link has no critical value: a certified bracket, or a link with no effect on the loop."""
    for c in report.get("critical_values") or []:
        if c["link"] == label or (label == "sensor" and c["link"] != "actuator"):
            if c.get("value_bracket"):
                lo, hi = c["value_bracket"]
                return f"in [{lo:.4g}, {hi:.4g}] (certified bracket)"
            if "no effect" in (c.get("note") or ""):
                return "none (the link has no effect)"
    return "none"


def headline_text(report: Mapping[str, Any], sx: _Axis, ax: _Axis) -> str:
    """The exact verdict at the request's point first, then the cost and the critical values."""
    cost = report.get("cost")
    cost_text = "unbounded" if cost is None else f"{cost:.6g}"
    s_val, s_exact = _critical(report, "sensor")
    a_val, a_exact = _critical(report, "actuator")
    return (
        f"{report['verdict'].upper()} ({THEOREM_TEXT}) at the request (star): "
        f"sensor {_short(sx.parameter)} {float(sx.value):.4g}, actuator {_short(ax.parameter)} {float(ax.value):.4g}\n"
        f"stationary cost {cost_text}; critical sensor {_short(sx.parameter)} "
        f"{_num(s_val, s_exact) if s_val is not None else _missing(report, 'sensor')}, "
        f"critical actuator {_short(ax.parameter)} "
        f"{_num(a_val, a_exact) if a_val is not None else _missing(report, 'actuator')}"
    )


def loop_region_figure(data: Mapping[str, Any]) -> Any:
    """Top: exact verdict per cell, exact boundary and the request; bottom: exact cost along each link."""
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    report, sx, ax_ = data["report"], data["sensor"], data["actuator"]
    fig = new_figure()
    fig.set_size_inches(7.0, 8.0)
    top, bottom = fig.subplots(2, 1)
    codes = np.array([[_CODE[v] for v in row] for row in data["labels"]])  # codes[i][j]: sensor i, actuator j
    cmap = ListedColormap(["#e8a0a0", "#f0f0c0", "#a0d0a0"])
    top.imshow(
        codes.T, origin="lower", extent=(0, 1, 0, 1), cmap=cmap, vmin=-1, vmax=1, interpolation="nearest", aspect="auto"
    )
    handles: list[Any] = [Patch(color="#a0d0a0", label="stable (exact, per cell)")]
    handles.append(Patch(color="#e8a0a0", label="unstable (exact, per cell)"))
    if (codes == 0).any():
        handles.append(Patch(color="#f0f0c0", label="boundary (exact, per cell)"))
    boundary = data["boundary"]
    if boundary is not None:
        xs = [r["sensor_arrival_probability"] for r in boundary["boundary"]]
        ys = [
            np.nan if r["critical_actuator_arrival_probability"] is None else r["critical_actuator_arrival_probability"]
            for r in boundary["boundary"]
        ]
        (line,) = top.plot(
            xs, ys, "o-", color="navy", ms=3, lw=1.6, gid=BOUNDARY_GID, label="exact critical actuator probability"
        )
        handles.append(line)
    x0, y0 = float(sx.value), float(ax_.value)
    for label, draw in (("sensor", top.axvline), ("actuator", top.axhline)):
        value, _ = _critical(report, label)
        if value is not None:
            handles.append(
                draw(value, color="blue", ls="--", lw=0.8, label=f"critical {label} at the request: {value:.4g}")
            )
    handles.append(top.scatter([x0], [y0], marker="*", s=160, c="blue", edgecolors="white", zorder=5, label="request"))
    top.set_xlim(0, 1)
    top.set_ylim(0, 1)
    top.set_xlabel(f"sensor {_short(sx.parameter)}")
    top.set_ylabel(f"actuator {_short(ax_.parameter)}")
    legend_beside(top, handles)
    along = np.array(data["along"])
    for axis, gid, colour in ((sx, SENSOR_COST_GID, "C0"), (ax_, ACTUATOR_COST_GID, "C1")):
        cost = np.array([np.nan if c is None else c for c in data["costs"][axis.label]], dtype=float)
        other = ax_ if axis is sx else sx
        bottom.plot(
            along,
            cost,
            color=colour,
            lw=1.5,
            gid=gid,
            label=f"against {axis.label} {_short(axis.parameter)} ({other.label} at {float(other.value):.4g})",
        )
        value, _ = _critical(report, axis.label)
        if value is not None:
            bottom.axvline(value, color=colour, ls="--", lw=1, label=f"critical {axis.label}: {value:.4g}")
    if report.get("cost") is not None:
        bottom.plot([x0], [report["cost"]], "*", color="C0", ms=11, label="request (sensor)")
        bottom.plot([y0], [report["cost"]], "*", color="C1", ms=11, label="request (actuator)")
    finite = np.concatenate(
        [np.array([np.nan if c is None else c for c in v], dtype=float) for v in data["costs"].values()]
    )
    finite = finite[np.isfinite(finite) & (finite > 0)]
    if finite.size and finite.max() / finite.min() > 50:
        bottom.set_yscale("log")
    bottom.set_xlim(0, 1)
    bottom.set_xlabel("the varied link's parameter (the other held at the request's value)")
    bottom.set_ylabel("stationary cost lim E[x'Wx + a'Ua]")
    bottom.grid(alpha=0.3, which="both")
    legend_beside(bottom)
    figure_headline(fig, headline_text(report, sx, ax_))
    return fig


__all__ = ["loop_region", "loop_region_data", "loop_region_figure"]
