"""Every plot: the title is the exact verdict and fits the figure; the legend never covers the axes; no text too small.

Before: titles were clipped at the API's figure size ("tability region...",
"verdict unstable (Theorem"), the simulation legend covered the data, and the
simulation title put the Monte Carlo picture before the exact verdict.  The
figures are read through :func:`kfio.service.plots.png_bytes`, the one place every
plot passes on its way to PNG bytes.
"""

from __future__ import annotations

import json

import pytest
from matplotlib.text import Text

from kfio import Budget, analyze, load_request
from kfio.service import plots
from kfio.service.api.schemas import REQUEST_EXAMPLES
from kfio.service.sweep_plot import sweep_figure
from kfio.sweep import load_sweep, run_sweep

from support.paths import ROOT


def _request(name: str, options: dict | None = None):
    body = json.loads(json.dumps(REQUEST_EXAMPLES[name]["value"]))
    if options is not None:
        body["options"] = options
    return load_request(json.dumps(body))


def _figure_of(monkeypatch, draw, request, params):
    seen = []
    monkeypatch.setattr(plots, "png_bytes", lambda fig: seen.append(fig) or b"")
    draw(request, Budget(seconds=300), params)
    (fig,) = seen
    return fig


def _check_layout(fig) -> str:
    """Every visible text inside the figure, the legend beside (not over) the axes; returns the title."""
    fig.canvas.draw()
    width, height = fig.bbox.width, fig.bbox.height
    (ax,) = fig.axes
    (x0, x1), (y0, y1) = sorted(ax.get_xlim()), sorted(ax.get_ylim())
    drawn_ticks = [t for t in ax.get_xticklabels() if x0 <= t.get_position()[0] <= x1] + [
        t for t in ax.get_yticklabels() if y0 <= t.get_position()[1] <= y1
    ]  # matplotlib keeps labels of ticks outside the view, undrawn
    texts = [fig._suptitle, ax.xaxis.label, ax.yaxis.label, *ax.get_legend().get_texts(), *drawn_ticks]
    for text in texts:
        assert isinstance(text, Text)
        if text.get_visible() and text.get_text().strip():
            box = text.get_window_extent()
            assert box.x0 >= -0.5 and box.x1 <= width + 0.5, text.get_text()
            assert box.y0 >= -0.5 and box.y1 <= height + 0.5, text.get_text()
    legend = ax.get_legend()
    assert legend is not None
    box, axes = legend.get_window_extent(), ax.get_window_extent()
    assert box.y0 >= axes.y1 or box.x0 >= axes.x1 or box.y1 <= axes.y0  # outside the axes: no data under it
    for text in texts:  # legible when the page shows the plot at 3/4 of its pixels
        if text.get_visible() and text.get_text().strip():
            assert text.get_fontsize() >= plots.MIN_FONT_PT, text.get_text()
    title = fig._suptitle
    assert title is not None
    return title.get_text()


def test_ge_region_plot_headlines_the_exact_verdict_and_marks_the_request(monkeypatch) -> None:
    request = _request("seed001-degenerate-gilbert-elliott")
    fig = _figure_of(monkeypatch, plots.ge_region, request, {"points": 5})
    title = _check_layout(fig)
    report = analyze(request)
    assert title.startswith(f"{report.verdict.upper()} (exact")
    (ax,) = fig.axes
    q0, p0 = float(request.channel.table[0]), 1 - float(request.channel.table[1])
    star = [c for c in ax.collections if c.get_label() == "request"]
    assert len(star) == 1 and star[0].get_offsets().tolist() == [[q0, p0]]
    # the critical rates of the report are in the title and drawn as ticks on the request's lines
    for c in report.gilbert_elliott.recovery.crossings:
        assert f"{c.value:.4g}" in title
        assert any(ln.get_marker() == "|" and list(ln.get_xdata()) == [c.value] for ln in ax.get_lines())
    for c in report.gilbert_elliott.failure.crossings:
        assert f"{c.value:.4g}" in title
        assert any(ln.get_marker() == "_" and list(ln.get_ydata()) == [c.value] for ln in ax.get_lines())


def test_two_sensor_region_plot_headlines_the_exact_verdict(monkeypatch) -> None:
    request = _request("seed000-two-sensors")
    title = _check_layout(_figure_of(monkeypatch, plots.region, request, {"points": 3}))
    assert title.startswith(f"{analyze(request).verdict.upper()} (exact")


def test_phase_transition_plot_headlines_the_exact_verdict(monkeypatch) -> None:
    request = _request("seed004-scalar")
    fig = _figure_of(monkeypatch, plots.phase_transition, request, {"points": 8})
    title = _check_layout(fig)
    report = analyze(request)
    assert title.startswith(f"{report.verdict.upper()} (exact")
    (ax,) = fig.axes
    exact = [ln for ln in ax.get_lines() if ln.get_label().startswith("lambda_c exact")]
    assert [ln.get_xdata()[0] for ln in exact] == [pytest.approx(float(report.critical_arrival_probability))]


def test_simulation_plot_headlines_the_exact_verdict_then_the_sample(monkeypatch) -> None:
    # the shipped bursty Gilbert-Elliott example: exact UNSTABLE, kappa = 0.44, the sample mean misleads
    body = json.loads(open("examples/simulate_bursty_ge.json").read())
    body["options"]["simulate"].update(steps=30, trajectories=400, exact_steps=5)
    request = load_request(json.dumps(body))
    title = _check_layout(_figure_of(monkeypatch, plots.simulation, request, {}))
    # a line too wide for the figure is wrapped, never set below the legible size: lines start as given
    assert title.startswith("UNSTABLE (exact, Rohr, Marelli and Fu 2014, Theorem 1)")
    assert "\nMonte Carlo: sample mean unreliable (kappa = 0.44 <= 2)" in title


def test_simulation_plot_says_when_no_exact_verdict_was_computed() -> None:
    from kfio.simulation._simulate import simulate

    request = _request("seed004-scalar", {"simulate": {"steps": 10, "trajectories": 50}})
    report = simulate(request).to_dict()
    report["stationary"] = None  # as when the exact analysis failed or ran out of budget
    fig = plots.simulation_figure(report, request)
    assert _check_layout(fig).startswith("exact verdict not computed")


def test_sweep_plot_title_says_whose_verdict_the_colours_are() -> None:
    spec = load_sweep(
        json.dumps(
            {
                "command": "analyze",
                "base": REQUEST_EXAMPLES["seed001-degenerate-gilbert-elliott"]["value"],
                "axes": [
                    {"pointer": "/channel/recovery_rate", "values": ["1/4", "3/4"]},
                    {"pointer": "/channel/failure_rate", "values": ["1/4", "3/4"]},
                ],
            }
        )
    )
    title = _check_layout(sweep_figure(run_sweep(spec, engine="serial")))
    assert "exact verdict per point (Rohr, Marelli and Fu 2014, Theorem 1)" in title


def test_one_axis_sweep_plot_names_a_long_critical_probability_by_its_decimal() -> None:

    pendulum = json.loads((ROOT / "examples" / "pendulum_c2d.json").read_text())
    spec = load_sweep(
        json.dumps(
            {
                "command": "analyze",
                "base": pendulum,
                "axes": [{"pointer": "/channel/arrival_probability", "values": ["1/2", "9/10"]}],
            }
        )
    )
    fig = sweep_figure(run_sweep(spec, engine="serial"))
    _check_layout(fig)
    (ax,) = fig.axes
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    exact = analyze(load_request(json.dumps(pendulum)))
    assert "CRootOf" in exact.critical_arrival_probability_exact
    (label,) = [t for t in labels if t.startswith("exact critical probability")]
    assert "CRootOf" not in label and label.endswith(f"{exact.critical_arrival_probability:.6g} (from float data)")
    (line,) = [ln for ln in ax.get_lines() if ln.get_label().startswith("exact critical probability")]
    assert list(line.get_xdata()) == [exact.critical_arrival_probability] * 2
