"""Sweep plots of loops: every point drawn with its verdict, the exact critical line and boundary, read back.

The figure is read as drawn (scatter offsets and colours, the threshold line, the boundary's
vertices, the cells) and compared with the sweep's rows and with :func:`kfio.loop.analyze_loop`
run independently on the points and vertices.  Before, unstable loop points (cost unbounded)
were plotted at 0 on a log axis, that is nowhere, and no exact line was drawn.
"""

from __future__ import annotations

import json
from fractions import Fraction

import numpy as np
import pytest
from matplotlib.colors import to_hex

from kfio.loop import analyze_loop, parse_loop_request
from kfio.service.sweep_plot import _COLORS, THRESHOLD_GID, sweep_figure
from kfio.sweep import load_sweep, run_sweep

from support.paths import ROOT

BASE = json.loads((ROOT / "examples" / "loop_scalar.json").read_text())
SENSOR, ACTUATOR = "/channel/arrival_probability", "/actuator_channel/arrival_probability"


def at(lam: str | None = None, nu: str | None = None) -> dict:
    tree = json.loads(json.dumps(BASE))
    if lam is not None:
        tree["channel"] = {"model": "bernoulli", "arrival_probability": lam}
    if nu is not None:
        tree["actuator_channel"] = {"model": "bernoulli", "arrival_probability": nu}
    return analyze_loop(parse_loop_request(tree)).to_dict()


def drawn_points(ax) -> list[tuple[float, str]]:
    """(x, colour) of every scatter marker, each checked to be inside the visible axes."""
    ax.figure.canvas.draw()
    box = ax.get_window_extent()
    out = []
    for coll in ax.collections:
        offsets = np.asarray(coll.get_offsets(), dtype=float)
        shown = coll.get_offset_transform().transform(offsets)
        colours = coll.get_facecolors()
        for k, ((x, _y), (px, py)) in enumerate(zip(offsets, shown)):
            assert np.isfinite(px) and np.isfinite(py), (x, "not drawn")
            assert box.x0 - 1 <= px <= box.x1 + 1 and box.y0 - 1 <= py <= box.y1 + 1, (x, "outside the axes")
            out.append((float(x), to_hex(colours[k % len(colours)])))
    return sorted(out)


@pytest.mark.slow
def test_one_axis_every_point_with_its_verdict_and_the_exact_critical_line() -> None:
    sweep = {
        "command": "loop",
        "base": BASE,
        "axes": [{"pointer": SENSOR, "from": "1/10", "to": "1", "num": 10, "name": "lambda"}],
    }
    result = run_sweep(load_sweep(json.dumps(sweep)), engine="serial")
    fig = sweep_figure(result)
    (ax,) = fig.axes
    rows = {float(Fraction(r.coordinates["lambda"])): r.fields["verdict"] for r in result.rows}
    assert set(rows.values()) == {"stable", "unstable"}  # both kinds are in this sweep
    expected = sorted((x, to_hex(_COLORS[v])) for x, v in rows.items())
    assert drawn_points(ax) == expected  # every point, unstable ones too, in its verdict's colour
    report = at()
    (line,) = [ln for ln in ax.get_lines() if ln.get_gid() == THRESHOLD_GID]
    assert list(line.get_xdata()) == [report["critical_sensor_arrival_probability"]] * 2
    assert report["critical_sensor_arrival_probability_exact"] == "9/16"
    assert line.get_label() == "exact critical probability 0.5625 = 9/16"
    for x, verdict in rows.items():  # the line separates the verdicts exactly
        assert verdict == ("stable" if Fraction(x) > Fraction(9, 16) else "unstable")
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "unstable, cost unbounded" in labels


@pytest.mark.slow
def test_two_axes_cells_and_the_exact_boundary_curve() -> None:
    sweep = {
        "command": "loop",
        "base": BASE,
        "axes": [
            {"pointer": SENSOR, "from": "1/20", "to": "19/20", "num": 7, "name": "lambda"},
            {"pointer": ACTUATOR, "from": "1/20", "to": "19/20", "num": 7, "name": "nu"},
        ],
    }
    result = run_sweep(load_sweep(json.dumps(sweep)), engine="serial")
    fig = sweep_figure(result)
    (ax,) = fig.axes
    (mesh,) = ax.collections
    grid = np.asarray(mesh.get_array()).reshape(7, 7)
    codes = {"stable": 0, "boundary": 1, "unstable": 2}
    for r in result.rows:
        i, j = divmod(r.index, 7)
        assert grid[j, i] == codes[r.fields["verdict"]]
    (curve,) = [ln for ln in ax.get_lines() if ln.get_label() == "exact boundary"]
    xs, ys = np.asarray(curve.get_xdata(), float), np.asarray(curve.get_ydata(), float)
    vertices = [(x, y) for x, y in zip(xs, ys) if np.isfinite(y)]
    assert vertices[0] == (0.5625, 1.0)  # leaves the top edge at the critical sensor probability 9/16
    for x, y in vertices[1::9]:  # every ninth vertex, recomputed on its own
        lam = Fraction(x).limit_denominator(1000)
        report = at(lam=f"{lam.numerator}/{lam.denominator}")
        assert y == report["critical_actuator_arrival_probability"]
        assert report["critical_actuator_arrival_probability_exact"] == "75/152"
