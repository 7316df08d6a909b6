"""PNG plots of 1-D and 2-D sweeps (matplotlib object API, Agg, no pyplot).

Everything drawn comes from the sweep's rows and from
:func:`kfio.sweep._boundary.exact_boundary` (library calls); this module only draws.
Axis labels are the sweep's axis names, drawn as plain text (no mathtext).  Every
point is drawn with its verdict: a point without a value to plot (an unstable
loop's cost is unbounded) sits on the top edge of the axes, a point with an
error on the bottom edge.  Numbers in labels are in kfio's one format
(:func:`kfio._numbers.number_text`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from kfio._numbers import number_text
from kfio.errors import InvalidInput
from kfio.model import parse_number
from kfio.sweep import SweepResult, exact_boundary

from .plots import GE_BOUNDARY_GID, figure_headline, legend_beside, new_figure, png_bytes

_COLORS = {"stable": "#2a9d8f", "boundary": "#e9c46a", "unstable": "#e76f51", None: "#bbbbbb"}
_METRIC = {"analyze": "worst_rate", "bounds": "trace_V_bar", "simulate": "final_mean_trace", "loop": "cost"}
_LABEL = {"analyze": "verdict", "bounds": "verdict_by_bounds", "simulate": "diverged", "loop": "verdict"}


def _coordinate(value: Any, name: str) -> float:
    try:
        return float(parse_number(value, name))
    except InvalidInput:
        raise InvalidInput("--plot", f"axis {name!r} has non-numeric values; only numeric sweeps are plotted") from None


def _label(command: str, fields: dict[str, Any]) -> str | None:
    if fields.get("error"):
        return None
    v = fields.get(_LABEL[command])
    if command == "simulate":
        return None if v is None else ("unstable" if v else "stable")
    return v


#: What each command's colours are: only ``analyze`` computes the exact verdict.
#: What a point without a plotted value means, per command (its marker sits on the top edge).
_NO_VALUE = {
    "analyze": "no rate",
    "bounds": "no V_bar",
    "simulate": "no final mean",
    "loop": "cost unbounded",
}
#: Gids that tests find the drawn parts by.
THRESHOLD_GID = "sweep-threshold"
_BARE_GID = "sweep-edge-points"

_WHAT = {
    "analyze": "exact verdict per point (Rohr, Marelli and Fu 2014, Theorem 1)",
    "bounds": "verdict of the bounds per point (Sinopoli et al. 2004); no exact verdict computed",
    "simulate": "Monte Carlo divergence per point; no exact verdict computed (sweep analyze for it)",
    "loop": "exact verdict of the loop per point (Costa, Fragoso and Marques 2005, Theorem 3.9)",
}


def sweep_png(result: SweepResult) -> bytes:
    """The PNG of :func:`sweep_figure`."""
    return png_bytes(sweep_figure(result))


def sweep_figure(result: SweepResult) -> Any:
    """A 1-D sweep as the key metric against the axis; a 2-D sweep as a labelled map.

    1-D ``analyze``: the worst rate ``|alpha|^2 sigma`` against the coordinate,
    coloured by verdict, with the line rate = 1 and the exact critical
    probability where kfio knows it.  2-D: each grid cell coloured by its
    verdict (grey: error), with the exact boundary of
    :func:`kfio.sweep._boundary.exact_boundary` (for a Gilbert-Elliott (p, q)
    sweep the lines of :func:`kfio.design._ge_boundary.boundary_lines`, the
    ones ``kfio analyze --ge-plot`` draws).  The title says whose verdict the
    colours are; the legend sits beside the axes.
    """
    spec = result.spec
    if spec.requests is not None or not 1 <= len(spec.axes) <= 2 or (len(spec.axes) == 2 and spec.combine != "grid"):
        raise InvalidInput("--plot", "plots are drawn for sweeps with one axis, or two axes combined as a grid")
    cmd = spec.command
    fig = new_figure()
    ax = fig.subplots()
    boundary = exact_boundary(spec)
    if len(spec.axes) == 1:
        a = spec.axes[0]
        x = np.array([_coordinate(r.coordinates[a.name], a.name) for r in result.rows])
        y = np.array(
            [np.nan if r.fields.get(_METRIC[cmd]) is None else float(r.fields[_METRIC[cmd]]) for r in result.rows]
        )
        labels = [_label(cmd, r.fields) for r in result.rows]
        ax.plot(x, y, color="#555555", lw=1, zorder=1)
        from matplotlib.transforms import blended_transform_factory

        edge = blended_transform_factory(ax.transData, ax.transAxes)  # x in data, y as a fraction of the axes
        for lab in ("stable", "boundary", "unstable", None):
            sel = np.array([lb == lab for lb in labels])
            valued = sel & ~np.isnan(y)
            if valued.any():
                ax.scatter(x[valued], y[valued], s=14, color=_COLORS[lab], zorder=2, label=lab or "error")
            bare = sel & np.isnan(y)
            if bare.any():
                # no value to plot (an unstable loop's cost): on the top edge, or on the bottom one for an error
                ax.scatter(
                    x[bare],
                    np.full(int(bare.sum()), 0.97 if lab else 0.03),
                    s=22,
                    marker="^" if lab else "x",
                    color=_COLORS[lab],
                    zorder=3,
                    transform=edge,
                    clip_on=False,
                    label=f"{lab}, {_NO_VALUE[cmd]}" if lab else "error (no value)",
                    gid=_BARE_GID,
                )
        if cmd == "analyze":
            ax.axhline(1.0, color="black", lw=0.8, ls="--", label="rate = 1")
        if boundary and boundary["kind"] == "threshold":
            ax.axvline(
                boundary["value"],
                color="#264653",
                lw=1.2,
                label=f"exact critical probability {number_text(boundary['exact'], boundary['value'])}",
                gid=THRESHOLD_GID,
            )
        if cmd != "analyze" and np.nanmin(np.where(y > 0, y, np.nan), initial=np.inf) < np.inf:
            ax.set_yscale("log")
        span = (x.max() - x.min()) or 1.0
        ax.set_xlim(x.min() - 0.03 * span, x.max() + 0.03 * span)  # every point, edge markers too
        if np.isnan(y).all():  # nothing valued: the edge markers need a visible axis
            ax.set_ylim(0, 1)
            ax.set_yticks([])
        ax.set_xlabel(a.name, parse_math=False)
        ax.set_ylabel(
            {
                "analyze": "worst rate |alpha|^2 sigma",
                "bounds": "trace V_bar",
                "simulate": "final mean trace P",
                "loop": "stationary cost (none: unbounded)",
            }[cmd]
        )
        legend_beside(ax)
    else:
        ax_x, ax_y = spec.axes
        xs = [_coordinate(v, ax_x.name) for v in ax_x.values]
        ys = [_coordinate(v, ax_y.name) for v in ax_y.values]
        codes = {"stable": 0, "boundary": 1, "unstable": 2, None: 3}
        grid = np.full((len(ys), len(xs)), 3.0)
        for r in result.rows:
            i, j = divmod(r.index, len(ys))  # grid order: the last axis (y) varies fastest
            grid[j, i] = codes[_label(cmd, r.fields)]
        from matplotlib.colors import ListedColormap
        from matplotlib.patches import Patch

        cmap = ListedColormap([_COLORS["stable"], _COLORS["boundary"], _COLORS["unstable"], _COLORS[None]])
        ax.pcolormesh(_edges(xs), _edges(ys), grid, cmap=cmap, vmin=-0.5, vmax=3.5, shading="flat")
        handles = [
            Patch(color=_COLORS[k], label=k or "error")
            for k in ("stable", "boundary", "unstable", None)
            if (grid == codes[k]).any()
        ]
        if boundary and boundary["kind"] == "curve":
            bx = np.array([np.nan if v is None else v for v in boundary["x"]], dtype=float)
            by = np.array([np.nan if v is None else v for v in boundary["y"]], dtype=float)
            (line,) = ax.plot(bx, by, color="black", lw=1.5, label="exact boundary", gid=GE_BOUNDARY_GID)
            handles.append(line)
        ex, ey = _edges(xs), _edges(ys)
        ax.set_xlim(ex.min(), ex.max())
        ax.set_ylim(ey.min(), ey.max())
        ax.set_xlabel(ax_x.name, parse_math=False)
        ax.set_ylabel(ax_y.name, parse_math=False)
        legend_beside(ax, handles)
    figure_headline(fig, f"kfio sweep {cmd}, {spec.size} points: {_WHAT[cmd]}")
    return fig


def _edges(v: list[float]) -> np.ndarray:
    """Cell edges around sorted centres (half-way between neighbours)."""
    c = np.array(v, dtype=float)
    if len(c) == 1:
        return np.array([c[0] - 0.5, c[0] + 0.5])
    mid = (c[1:] + c[:-1]) / 2
    return np.concatenate([[c[0] - (mid[0] - c[0])], mid, [c[-1] + (c[-1] - mid[-1])]])


__all__ = ["THRESHOLD_GID", "sweep_figure", "sweep_png"]
