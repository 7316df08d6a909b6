"""The JSON views of ``kfio analyze``: the verdict, the tail, the Gilbert-Elliott region, a critical parameter.

Each view returns a report object's JSON fields as raw values (floats, tuples,
nested report objects); :func:`kfio._json.encode` applies the mechanical rules.
Field names and constant texts are the stable JSON of the README.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ..stability import (
        BlockReport,
        BlockTail,
        CriticalParameter,
        Crossing,
        GeMap,
        GeRegion,
        LineResult,
        ParameterConstraint,
        StabilityReport,
        TailReport,
    )

THEOREM_1 = "Rohr, Marelli and Fu 2014, Theorem 1"
GE_REFERENCE = (
    "Rohr, Marelli and Fu (2014), Theorem 1, on the Gilbert-Elliott family; Wu, Shi, Anderson and Johansson (2018)"
)
TAIL_RULE = "P(trace P > M) ~ M^(-kappa); the moment of order r is finite iff kappa > r"


def as_float(x: Any) -> float | None:
    """``float(x)`` for a number a view reports as a float (the encoder maps NaN and infinities to null)."""
    return None if x is None else float(x)


def stability_report(r: StabilityReport) -> dict[str, Any]:
    """``kfio analyze --json``: Theorem 1 of Rohr, Marelli and Fu (2014) per FMO block, with its extensions."""
    return {
        "verdict": r.verdict,
        "theorem": THEOREM_1,
        "blocks": r.blocks,
        "critical_arrival_probability": as_float(r.critical_arrival_probability),
        "critical_arrival_probability_exact": r.critical_arrival_probability_exact,
        "channel": r.channel,
        "system": r.system,
        "assumptions": r.assumptions,
        "warnings": r.warnings,
        "regions": r.regions,
        "tail": r.tail,
        "gilbert_elliott_region": r.gilbert_elliott,
        "critical_parameter": r.critical_parameter,
    }


def block_report(b: BlockReport) -> dict[str, Any]:
    """One FMO block: ``|alpha|``, ``sigma`` and the rate ``|alpha|^2 sigma`` of Theorem 1."""
    return {
        "eigenvalues": b.eigenvalues,
        "eigenvalues_numeric": [complex(z) for z in b.eigenvalues_numeric],
        "modulus": as_float(b.modulus),
        "modulus_exact": b.modulus_exact,
        "jordan_sizes": b.jordan_sizes,
        "period": b.period,
        "degenerate": b.degenerate,
        "sigma": as_float(b.sigma),
        "sigma_exact": b.sigma_exact,
        "rate": as_float(b.rate),
        "verdict": b.verdict,
        "certified": b.certified,
        "blind_set": b.blind_set,
        "basis": b.basis,
        "notes": b.notes,
    }


def tail_report(t: TailReport) -> dict[str, Any]:
    """The tail exponent ``kappa = min_k kappa_k`` (Mo and Sinopoli, 2012) and the moments it implies."""
    return {
        "kappa": t.kappa,
        "kappa_exact": t.kappa_exact,
        "moments": t.moments,
        "statement": t.statement,
        "rule": TAIL_RULE,
        "basis": t.basis,
        "blocks": t.blocks,
        "notes": t.notes,
    }


def block_tail(b: BlockTail) -> dict[str, Any]:
    """``kappa_k = log(1 / sigma_k) / (2 log |alpha_k|)`` of one block."""
    return {
        "eigenvalues": b.eigenvalues,
        "kappa": b.kappa,
        "kappa_exact": b.kappa_exact,
        "sigma_exact": b.sigma_exact,
        "moments": b.moments,
        "exact": b.exact,
        "basis": b.basis,
        "reference": b.reference,
    }


def ge_region(g: GeRegion) -> dict[str, Any]:
    """The Gilbert-Elliott region: critical rates on the request's lines, patterns, optional map."""
    return {
        "basis": g.basis,
        "reference": GE_REFERENCE,
        "critical_recovery_rate": g.recovery,
        "critical_failure_rate": g.failure,
        "patterns": [pt.describe() for pt in g.patterns],
        "map": g.map,
    }


def line_result(line: LineResult) -> dict[str, Any]:
    """The exact verdict along one line of the (p, q) square and its critical values."""
    crit = line.critical
    return {
        "variable": line.variable,
        "fixed": line.fixed,
        "status": line.status(),
        "critical": crit.value if crit else None,
        "critical_exact": crit.value_exact if crit else None,
        "crossings": line.crossings,
        "intervals": _intervals(line.intervals),
        "exact": line.exact,
    }


def crossing(c: Crossing) -> dict[str, Any]:
    """A change of the exact label along a line, with the pattern that decides it."""
    # a Gilbert-Elliott pattern describes itself: the map lists the same description per piece
    return _crossing(c.value, c.value_exact, c.left, c.right, None if c.pattern is None else c.pattern.describe())


def ge_map(m: GeMap) -> dict[str, Any]:
    """Exact labels on the grid of cell centres and the sampled boundary curve."""
    return {
        "grid": len(m.rates),
        "rates": m.rates,
        "labels": m.labels,
        "label_axes": "labels[i][j]: failure_rate p = rates[i], recovery_rate q = rates[j]",
        "exact_labels": m.exact,
        "pieces": m.pieces,
        "curve": m.curve,
        "curve_columns": ["recovery_rate", "failure_rate", "piece"],
    }


def critical_parameter(c: CriticalParameter) -> dict[str, Any]:
    """The verdict along one channel parameter in ``(0, 1)``, the others fixed (Theorem 1 on a family)."""
    crit = c.crossings[0] if len(c.crossings) == 1 else None
    return {
        "pointer": c.pointer,
        "value": str(c.value),
        "critical": crit.value if crit else None,
        "critical_exact": crit.exact_text if crit else None,
        "crossings": [_crossing(x.value, x.exact_text, x.left, x.right, x.tag) for x in c.crossings],
        "intervals": _intervals(c.intervals),
        "exact": c.exact,
        "basis": c.basis,
    }


def constraint(c: ParameterConstraint) -> dict[str, Any]:
    """The block and maximal blind set whose rate decides a crossing of a critical parameter."""
    return {
        "block": c.block,
        "eigenvalues": c.eigenvalues,
        "period": c.period,
        "blind_set": sorted([list(s) for s in c.blind_set]),
    }


def _crossing(value: Any, exact: str | None, left: str, right: str, deciding: Any) -> dict[str, Any]:
    return {
        "value": value,
        "value_exact": exact,
        "below": left,
        "above": right,
        **({"deciding": deciding} if deciding is not None else {}),
    }


def _intervals(intervals: Any) -> list[dict[str, Any]]:
    return [{"lower": a, "upper": b, "label": lab} for a, b, lab in intervals]


__all__ = [
    "block_report",
    "block_tail",
    "constraint",
    "critical_parameter",
    "crossing",
    "ge_map",
    "ge_region",
    "line_result",
    "stability_report",
    "tail_report",
]
