"""The JSON views of the per-sensor exact regions (an extension of Rohr, Marelli and Fu 2014, Theorem 1).

Blind patterns count misses per sensor, so their views take the sensor names
as context: :func:`blind_pattern`, :func:`block_constraints`,
:func:`sensor_threshold` and :func:`boundary_piece` are called by the view of
the object that knows the names (:class:`~kfio.design._regions.SensorThresholds`,
:class:`~kfio.design._regions_curve.BoundaryCurve`,
:class:`~kfio.design._sensor_gain.SensorGains`), never reached alone.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Sequence

from ..model import fraction_text
from ._stability import as_float

if TYPE_CHECKING:
    from ..stability import (
        BlindPattern,
        BlockConstraints,
        BoundaryCurve,
        BoundaryPiece,
        Envelope,
        RegionGrid,
        Segment,
        SensorGains,
        SensorThreshold,
        SensorThresholds,
    )

BASIS = "extension"
STATEMENT = (
    "the FMO construction of Rohr, Marelli and Fu 2014 applied to separately lost Bernoulli packets "
    "(docs/theory.md, 'Per-sensor exact regions'); a kfio extension, not a theorem of the papers"
)
HALF_SPACES = "sum_s misses_s * (-log(1 - lambda_s)) > period * log(modulus_squared), one per pattern"


def sensor_thresholds(t: SensorThresholds) -> dict[str, Any]:
    """Per-sensor exact thresholds and the verdict at the operating point (the ``regions`` block)."""
    return {
        "basis": BASIS,
        "statement": STATEMENT,
        "verdict": t.verdict,
        "certified": t.certified,
        "consistent_with_analyze": t.consistent_with_analyze,
        "blocks": [
            {**block_constraints(b, t.sensors), "verdict": v, "rate": as_float(r)}
            for b, v, r in zip(t.blocks, t.block_verdicts, t.block_rates)
        ],
        "sensors": [sensor_threshold(s, t.sensors) for s in t.thresholds],
    }


def sensor_threshold(s: SensorThreshold, names: Sequence[str]) -> dict[str, Any]:
    """The critical arrival probability of one sensor, the others at their values."""
    b = s.binding
    return {
        "sensor": s.sensor,
        "arrival_probability": float(s.arrival_probability),
        "arrival_probability_exact": fraction_text(s.arrival_probability),
        "status": s.status,
        "critical_arrival_probability": s.critical,
        "critical_arrival_probability_exact": s.critical_exact,
        "binding": None if b is None else {"block": b[0], "eigenvalues": b[1], **blind_pattern(b[2], names)},
        "certified": s.certified,
        "reason": s.reason,
    }


def block_constraints(b: BlockConstraints, names: Sequence[str]) -> dict[str, Any]:
    """The half-spaces ``sum_s z_s(F) u_s > N log beta`` of one FMO block."""
    return {
        "eigenvalues": b.eigenvalues,
        "modulus_squared": as_float(b.beta_float),
        "modulus_squared_exact": b.beta_text if b.beta is not None else None,
        "period": b.period,
        "half_spaces": HALF_SPACES,
        "patterns": [blind_pattern(p, names) for p in b.patterns],
        "certified": b.certified,
        "notes": b.notes,
    }


def blind_pattern(p: BlindPattern, names: Sequence[str]) -> dict[str, Any]:
    """One maximal blind set: its (phase, sensor) slots and the misses ``z_s`` keyed by sensor name."""
    return {"blind_set": p.slots, "misses": dict(zip(names, p.misses))}


def region_grid(g: RegionGrid) -> dict[str, Any]:
    """The two-sensor square labelled exactly, with the boundary curve."""
    return {
        "basis": BASIS,
        "statement": STATEMENT,
        "axes": g.axes,
        "values": [float(v) for v in g.values],
        "values_exact": [fraction_text(v) for v in g.values],
        "labels": g.labels,
        "indexing": "labels[i][j] is the cell lambda_1 = values[i], lambda_2 = values[j]",
        "legend": {
            "stable": "every FMO block has rate < 1 (exact comparison)",
            "unstable": "some FMO block has rate > 1",
            "boundary": "the largest block rate is exactly 1: the theorem's gap",
        },
        "edge_cells": (
            "cells with lambda = 0 or 1 lie outside Assumption 1 of Rohr, Marelli and Fu 2014; they are labelled by the same "
            "formula (0^0 = 1: a sensor that always arrives removes every pattern that misses it)"
        ),
        "certified": g.certified,
        "boundary": g.curve,
    }


def boundary_curve(c: BoundaryCurve) -> dict[str, Any]:
    """The exact boundary ``lambda_2 = h(lambda_1)`` of two Bernoulli sensors, piece by piece."""
    return {
        "basis": BASIS,
        "axes": c.axes,
        "meaning": (
            "stable iff lambda_1 > lambda_1_min and lambda_2 > h(lambda_1); boundary (the theorem's gap) on the "
            "curve; unstable below it.  h is the largest active piece, in closed form per (block, blind pattern)"
        ),
        "pieces": [boundary_piece(p, c.axes) for p in c.pieces],
        "envelope": c.envelope,
        "per_block": [{"eigenvalues": e, **envelope(env)} for e, env in c.per_block],
        "samples": {
            "lambda_1": [x for x, _ in c.samples],
            "lambda_2": [y for _, y in c.samples],
        },
    }


def boundary_piece(p: BoundaryPiece, names: Sequence[str]) -> dict[str, Any]:
    """One closed-form piece ``lambda_2 = 1 - beta^(-N/z_2) (1 - lambda_1)^(-z_1/z_2)``."""
    z1, z2 = p.pattern.misses
    return {
        "block": p.block,
        "eigenvalues": p.eigenvalues,
        "period": p.period,
        "modulus_squared_exact": p.beta_text,
        "blind_set": p.pattern.slots,
        "misses": {names[0]: z1, names[1]: z2},
        "log_form": f"{z1} u_1 + {z2} u_2 = {p.period} log({p.beta_text}),  u_s = -log(1 - lambda_s)",
        "formula": p.formula,
    }


def envelope(e: Envelope) -> dict[str, Any]:
    """Where the region starts and which piece is active on each interval of ``lambda_1``."""
    return {
        "lambda_1_min": e.lambda_1_min,
        "lambda_1_min_exact": e.lambda_1_min_exact,
        "lambda_1_min_strict": e.vertical,
        "segments": e.segments,
    }


def segment(s: Segment) -> dict[str, Any]:
    """``lambda_1`` in ``(start, end)`` where one piece (or ``h = 0``) is the envelope."""
    return {
        "lambda_1_from": s.start,
        "lambda_1_to": s.end,
        "lambda_1_from_exact": s.start_exact,
        "lambda_1_to_exact": s.end_exact,
        "piece": s.piece,
    }


def sensor_gains(g: SensorGains) -> dict[str, Any]:
    """Elasticities ``z_s / N`` of the binding pattern and the worst rate after halving each loss probability."""
    if g.binding is None:
        return {"basis": BASIS, "worst_rate": 0.0, "best": None, "sensors": []}
    return {
        "basis": BASIS,
        "worst_rate": as_float(g.worst_rate),
        "worst_block": g.worst_block,
        "binding_pattern": blind_pattern(g.binding, g.names),
        "best": g.best,
        "sensors": [
            {
                "sensor": s.sensor,
                "elasticity_exact": str(s.elasticity),
                "elasticity": float(s.elasticity),
                "worst_rate_if_loss_halved": as_float(s.worst_rate_if_loss_halved),
            }
            for s in g.sensors
        ],
        "rule": "elasticity = d log(worst rate) / d log(1 - lambda_s) = z_s / N of the binding pattern",
    }


__all__ = [
    "blind_pattern",
    "block_constraints",
    "boundary_curve",
    "boundary_piece",
    "envelope",
    "region_grid",
    "segment",
    "sensor_gains",
    "sensor_threshold",
    "sensor_thresholds",
]
