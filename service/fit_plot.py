"""``POST /v1/plots/trace-region``: the confidence region of a fitted channel over kfio's exact stable region.

The body is an analyze request whose channel is a measured trace
(``{"model": "trace", "arrivals": "..."}``, ``docs/traces.md``).  Drawn:

* Bernoulli: the arrival-probability axis split at the exact critical
  probability ``lambda_c`` (Rohr, Marelli and Fu 2014, Corollary 2) into its
  unstable and stable parts, the confidence interval as a box over it, the
  estimate marked;
* Gilbert-Elliott: the exact (recovery rate q, failure rate p) map and
  boundary of ``kfio analyze --ge-plot`` (:func:`kfio.service.plots.ge_region_figure`),
  with the Bonferroni box drawn over it and its corners marked by their exact verdicts.

A Markov channel of order ``k`` has a ``2^k``-dimensional box: no plot (422).
"""

from __future__ import annotations

import dataclasses
from typing import Any, Mapping

from kfio import Budget
from kfio._numbers import number_text
from kfio.errors import InvalidInput

from .plots import figure_headline, ge_region_figure, new_figure, png_bytes

_COLOURS = {"stable": "#2a7a2a", "unstable": "#b02020", None: "#808080", "boundary": "#b0a000"}


def trace_region(body: bytes, limits: Any, budget: Budget, params: Mapping[str, Any]) -> bytes:
    """The PNG of the module docstring for an analyze request ``body`` with a trace channel."""
    from kfio.fit import analyze_at_confidence, load_trace_request
    from kfio.stability import analyze

    request, fits = load_trace_request(body, limits)
    found = fits.get("/channel")
    if found is None:
        raise InvalidInput("/channel/model", 'the trace-region plot needs a trace channel: {"model": "trace", ...}')
    if found.model == "markov":
        raise InvalidInput(
            "/channel/arrivals",
            f"the trace fits a Markov channel of order {found.order}: its confidence box has {len(found.trials)} "
            "dimensions, which this plot cannot draw (the report's fit block gives it)",
        )
    if found.model == "gilbert_elliott":
        opts = {**request.options.get("analyze", {}), "ge_grid": int(params.get("points", 41))}
        report = analyze(dataclasses.replace(request, options={**request.options, "analyze": opts}), budget)
    else:
        report = analyze(request, budget)
    block = analyze_at_confidence(request, found, report.verdict, budget)
    if found.model == "gilbert_elliott":
        fig = ge_region_figure(report.gilbert_elliott, report.verdict, request)
        _draw_box(fig.axes[0], block)
        return png_bytes(fig)
    return png_bytes(_bernoulli_figure(report, block))


def _draw_box(ax: Any, block: Any) -> None:
    """The (q, p) box over the Gilbert-Elliott figure, its worst and best corners coloured by their verdicts."""
    from matplotlib.patches import Rectangle

    (plo, phi), (qlo, qhi) = block.intervals["failure_rate"], block.intervals["recovery_rate"]
    colour = _COLOURS.get(block.verdict, "black")
    ax.add_patch(
        Rectangle(
            (qlo, plo),
            qhi - qlo,
            phi - plo,
            fill=False,
            edgecolor=colour,
            linewidth=1.6,
            label=f"{float(block.level) * 100:g}% confidence box: {block.verdict}",
            gid="confidence-box",
        )
    )
    for name, corner in block.corners.items():
        ch = corner["channel"]
        q, p = float(_fraction(ch["recovery_rate"])), float(_fraction(ch["failure_rate"]))
        ax.plot([q], [p], "s", color=_COLOURS.get(corner["verdict"], "gray"), markersize=4, label=f"{name} corner")
    ax.legend(loc="upper right", fontsize=7)


def _fraction(text: str) -> Any:
    from kfio.model import parse_number

    return parse_number(text, "/channel")


def _bernoulli_figure(report: Any, block: Any) -> Any:
    """The arrival-probability axis split at ``lambda_c``, with the confidence interval over it."""
    fig = new_figure()
    ax = fig.subplots()
    crit = report.critical_arrival_probability
    lo, hi = block.intervals["arrival_probability"]
    estimate = float(block.fit.estimates["arrival_probability"])
    if crit is not None:
        ax.axvspan(0.0, crit, color="#e8a0a0", label="unstable (exact)")
        ax.axvspan(crit, 1.0, color="#a0d0a0", label="stable (exact)")
        ax.axvline(crit, color="black", linewidth=1.0)
        ax.annotate(
            f"lambda_c = {number_text(report.critical_arrival_probability_exact, crit)}",
            (crit, 0.92),
            xytext=(4, 0),
            textcoords="offset points",
            fontsize=8,
        )
    ax.fill_between(
        [lo, hi],
        [0.35, 0.35],
        [0.65, 0.65],
        facecolor="none",
        edgecolor=_COLOURS.get(block.verdict, "black"),
        linewidth=1.6,
        label=f"{float(block.level) * 100:g}% confidence interval: {block.verdict}",
        gid="confidence-box",
    )
    ax.plot([estimate], [0.5], "k*", markersize=9, label=f"estimate {block.fit.parameters['arrival_probability']}")
    width = max(hi - lo, 0.02)
    left = max(0.0, min(lo, crit if crit is not None else lo) - 2 * width)
    right = min(1.0, max(hi, crit if crit is not None else hi) + 2 * width)
    ax.set_xlim(left, right)
    ax.set_ylim(0.0, 1.0)
    ax.set_yticks([])
    ax.set_xlabel("arrival probability lambda")
    ax.legend(loc="lower right", fontsize=7)
    needed = "" if block.samples_needed is None else f"; about {block.samples_needed} packets would decide"
    figure_headline(
        fig,
        f"{block.verdict} at {float(block.level) * 100:g}% confidence ({block.fit.samples} packets{needed}); "
        f"estimate: {report.verdict} (Rohr, Marelli and Fu 2014, Theorem 1)",
    )
    return fig


__all__ = ["trace_region"]
