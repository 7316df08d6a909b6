"""The JSON views of ``kfio loop``: the exact verdict first, cost and critical link reliabilities beside it.

Each view returns a report object's fields as raw values; :func:`kfio._json.encode`
applies the mechanical rules.  Field names and constant texts are the stable JSON of
``docs/loop.md`` (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007;
Costa, Fragoso and Marques 2005).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ..loop import BoundaryPoint, EstimatorAlone, LoopReport, Region, UdpOuterBound, UdpRegionBounds
    from ..loop._lqg_critical import ActuatorCritical
    from ..loop._lqg_types import LqgCostBounds, LqgOptimal, LqgPart, RiccatiSolve

THEOREM = "Costa, Fragoso and Marques 2005, Theorem 3.9 (mean-square stability of Markov jump linear systems)"
MODEL = "Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. II (sensor and actuator packet losses)"
REGION_RULE = (
    "stable iff the actuator arrival probability exceeds the critical value at that sensor "
    "arrival probability (null: no actuator probability stabilizes the loop there)"
)
LQG_PAPER = "Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V"
UDP_KIND = (
    "bounds on the critical region of the optimal UDP-like controller, proved in kfio's "
    "documentation (not the paper's Sec. VI statement)"
)
UDP_INNER = (
    "the exact stable region of the given gains (region and critical values above): the optimal "
    "UDP-like cost is finite wherever these gains are mean-square stable"
)


def _enclosure(box: Any) -> list[str] | None:
    from ..model import decimal_enclosure

    return None if box is None else list(decimal_enclosure(*box))


def _matrix(m: Any) -> list[list[str]]:
    from ..model import fraction_text

    return [[fraction_text(x) for x in row] for row in m]


def loop_report(r: LoopReport) -> dict[str, Any]:
    """``kfio loop --json``."""
    req = r.request
    return {
        "verdict": r.verdict,
        "theorem": THEOREM,
        "model": MODEL,
        "exact": r.exact,
        "certified": r.certified,
        "certificate": r.certificate,
        "partial": r.partial,
        "spectral_radius": r.spectral_radius,
        "spectral_radius_exact": r.spectral_radius_exact,
        "spectral_radius_enclosure": _enclosure(r.spectral_radius_enclosure),
        "operator_size": r.operator_size,
        "modes": r.modes,
        "cost": r.cost,
        "cost_exact": r.cost_exact,
        "cost_exact_digits": r.cost_exact_digits,
        "cost_enclosure": r.cost_enclosure,
        "critical_sensor_arrival_probability": r.critical_sensor_arrival_probability,
        "critical_sensor_arrival_probability_exact": r.critical_sensor_arrival_probability_exact,
        "critical_actuator_arrival_probability": r.critical_actuator_arrival_probability,
        "critical_actuator_arrival_probability_exact": r.critical_actuator_arrival_probability_exact,
        "critical_values": [c.as_dict() for c in r.critical],
        "estimator_alone": r.estimator_alone,
        "region": r.region,
        "lqg": r.lqg,
        "udp_region_bounds": r.udp_region_bounds,
        "loop": {
            "protocol": req.protocol,
            "on_loss": req.on_loss,
            "form": req.form,
            "controller": req.controller,
            "feedback": _matrix(req.feedback) if req.feedback else None,
            "estimator": _matrix(req.estimator) if req.estimator else None,
        },
        "notes": list(r.notes),
    }


def estimator_alone(e: EstimatorAlone) -> dict[str, Any]:
    """The fixed estimator gain without control, beside the optimal time-varying filter."""
    opt = e.optimal_filter
    return {
        "verdict": e.verdict,
        "spectral_radius": e.spectral_radius,
        "spectral_radius_exact": e.spectral_radius_exact,
        "stationary_error_trace": e.stationary_error_trace,
        "stationary_error_trace_exact": e.stationary_error_trace_exact,
        "critical_sensor_arrival_probability": e.critical_sensor_arrival_probability,
        "critical_sensor_arrival_probability_exact": e.critical_sensor_arrival_probability_exact,
        "critical_value": None if e.critical is None else e.critical.as_dict(),
        "optimal_filter_critical_arrival_probability": opt.critical_arrival_probability,
        "optimal_filter_critical_arrival_probability_exact": opt.critical_arrival_probability_exact,
        "optimal_filter_note": opt.note,
        "statement": e.statement,
    }


def region(r: Region) -> dict[str, Any]:
    """``options.loop.region``: points of the boundary of the stable region of the given gains."""
    return {"boundary": r.boundary, "rule": REGION_RULE}


def boundary_point(p: BoundaryPoint) -> dict[str, Any]:
    """One boundary point: the sensor arrival probability and the exact critical actuator one there."""
    from ..model import fraction_text

    c = p.critical
    return {
        "sensor_arrival_probability": p.sensor_arrival_probability,
        "sensor_arrival_probability_exact": fraction_text(p.sensor),
        "critical_actuator_arrival_probability": c.value,
        "critical_actuator_arrival_probability_exact": c.exact,
        "note": None if c.value is not None else c.note,
    }


def udp_region_bounds(u: UdpRegionBounds) -> dict[str, Any]:
    """Bounds on the optimal UDP-like critical region, labelled as bounds."""
    return {
        "kind": UDP_KIND,
        "outer": u.outer,
        "inner": UDP_INNER,
        "request_point_inside_optimal_region": u.request_point_inside_optimal_region,
        "reason": u.reason,
    }


def udp_outer_bound(o: UdpOuterBound) -> dict[str, Any]:
    """The necessary sensor and actuator arrival probabilities of any design."""
    sensor_from = "the optimal filter's critical value (Theorem 1, kfio analyze); below it E[P(t|t)] is " + (
        "unbounded under any controller" + ("" if o.sensor_note is None else f" (not available: {o.sensor_note})")
    )
    actuator_from = (
        "not available with on_loss: hold (a lost packet applies the last input)"
        if o.held
        else "1 - 1/rho(A)^2: below it E[x x'] >= (1 - nu) A E[x x'] A' + Q diverges under any controller"
    )
    return {
        "sensor_arrival_probability_above": o.sensor_arrival_probability_above,
        "sensor_arrival_probability_above_exact": o.sensor_arrival_probability_above_exact,
        "sensor_from": sensor_from,
        "actuator_arrival_probability_above": o.actuator_arrival_probability_above,
        "actuator_arrival_probability_above_exact": o.actuator_arrival_probability_above_exact,
        "actuator_from": actuator_from,
    }


def _cost_bounds_view(b: LqgCostBounds) -> dict[str, Any]:
    out: dict[str, Any] = {
        "lower": b.lower,
        "upper": b.upper,
        "lower_from": b.lower_from,
        "upper_from": b.upper_from,
        "paper_upper": b.paper_upper,
        "reason": b.reason,
    }
    if b.S is not None:
        out.update(
            formula="J_inf = tr(S Q) + tr((A'SA + W - S) E[P(t|t)]), S the control MARE's fixed point",
            covariance="filtered P(t|t) of the optimal time-varying Kalman filter (time average of its expectation)",
            tr_S_Q=b.tr_S_Q,
            S=b.S,
            applies_to="the optimal TCP-like controller (time-varying Kalman filter, stationary L); "
            "the exact `cost` above is that of the stationary gains, at least J_inf",
            reference=LQG_PAPER,
        )
    return out


def _actuator_view(a: ActuatorCritical) -> dict[str, Any]:
    return {
        "lower": a.lower,
        "upper": a.upper,
        "is_exact": a.is_exact,
        "from": a.source,
        "stabilizable": a.stabilizable,
    }


def _riccati_view(r: RiccatiSolve | None) -> dict[str, Any] | None:
    if r is None:
        return None
    return {
        "equation": r.equation,
        "method": "Newton's method (policy iteration) from stabilizing gains, continued from probability 1",
        "relative_residual": r.residual,
        "newton_steps": r.newton_steps,
        "continuation_points": r.continuation_points,
        "trace": r.trace,
    }


def _optimal_view(o: LqgOptimal) -> dict[str, Any]:
    a = o.actuator
    return {
        "verdict": o.verdict,
        "reasons": list(o.reasons),
        "critical_sensor_arrival_probability": o.critical_sensor,
        "critical_sensor_arrival_probability_exact": o.critical_sensor_exact,
        "critical_sensor_from": "the optimal time-varying filter (kfio analyze, Rohr, Marelli and Fu 2014, Theorem 1)",
        "critical_sensor_note": o.sensor_note,
        "critical_actuator_arrival_probability": a.value,
        "critical_actuator_arrival_probability_exact": a.exact,
        "critical_actuator": _actuator_view(a),
        "cost_bounds": _cost_bounds_view(o.cost_bounds),
        "statement": o.statement,
        "reference": LQG_PAPER,
    }


def lqg_part(p: LqgPart) -> dict[str, Any]:
    """The ``lqg`` block: ``optimal`` (the optimal TCP-like controller) and the stationary gains' derivation."""
    return {
        "optimal": _optimal_view(p.optimal),
        "stationary_gains": {
            "exist": p.gains,
            "form": p.form,
            "applies_to": "the top level: the exact analysis of these stationary gains",
            "control_riccati": _riccati_view(p.control_riccati),
            "estimation_riccati": _riccati_view(p.estimation_riccati),
        },
    }
