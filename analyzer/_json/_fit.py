"""The JSON views of ``kfio fit`` and of the verdict at a stated confidence (the ``fit`` block)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ..fit import ConfidenceVerdict, FitReport


def fit_report(r: FitReport) -> dict[str, Any]:
    """``kfio fit --json`` and ``POST /v1/fit``: the chosen model, exact estimates, intervals, scores, fit check."""
    return {
        "model": r.model,
        "order": r.order,
        "parameters": r.parameters,
        "intervals": r.intervals,
        "marginal_intervals": r.marginal_intervals,
        "level": float(r.level),
        "interval_method": r.interval_method,
        "samples": r.samples,
        "counts": r.counts,
        "criterion": r.criterion,
        "scores": r.scores,
        "goodness_of_fit": r.goodness_of_fit,
        "channel": r.channel,
        "source": r.source,
        "sequence": r.sequence,
        "warnings": r.warnings,
        "notes": r.notes,
    }


def confidence_verdict(v: ConfidenceVerdict) -> dict[str, Any]:
    """The ``fit`` block of ``kfio analyze|loop --trace``: the verdict of the whole confidence region."""
    return {
        "link": v.link,
        "model": v.fit.model,
        "order": v.fit.order,
        "parameters": v.fit.parameters,
        "intervals": v.intervals,
        "level": float(v.level),
        "interval_method": v.interval_method,
        "samples": v.fit.samples,
        "verdict": v.verdict,
        "samples_needed": v.samples_needed,
        "corners": v.corners,
        "method": v.method,
        "channel": v.fit.channel,
        "warnings": v.fit.warnings + v.warnings,
    }
