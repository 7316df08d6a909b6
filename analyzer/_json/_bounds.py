"""The JSON views of ``kfio bounds`` (Sinopoli et al. 2004; Liu and Goldsmith 2004; Rohr, Marelli and Fu 2010).

Every key is always present; a value that does not exist is ``null`` next to a
``reason``; matrices are nested lists; exact rationals are strings such as ``"9/25"``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ..model import fraction_text
from ._stability import as_float

if TYPE_CHECKING:
    from ..riccati_bounds import (
        BoundsReport,
        CovarianceBounds,
        CriticalInterval,
        FilteredBounds,
        PHatBounds,
        RegionMap,
        StabilityCertificate,
        TraceTarget,
    )

#: Relative agreement required between the V_bar iteration and the SDP.
SDP_AGREEMENT = 1e-6


def _trace(M: np.ndarray | None) -> float | None:
    return None if M is None else float(np.trace(M))


def _matrix(M: np.ndarray | None) -> Any:
    return None if M is None else np.atleast_2d(np.asarray(M, dtype=float))


def bounds_report(r: BoundsReport) -> dict[str, Any]:
    """``kfio bounds --json``: the critical-probability interval, ``S_bar <= lim E[P] <= V_bar``, ``P_hat_N``."""
    one = r.one_packet
    packets = [
        {
            "name": p.name,
            "rows": p.rows,
            "arrival_probability": float(lam),
            "arrival_probability_exact": fraction_text(lam),
        }
        for p, lam in zip(r.packets, r.arrival)
    ]
    sensors = None
    if not one:
        sensors = [{"name": p.name, "critical_interval": c} for p, c in zip(r.packets, r.critical)]
    return {
        "command": "bounds",
        "packets": packets,
        "spectral_radius_A": as_float(r.rho),
        "hypotheses": r.hypotheses,
        "operating_point": {
            "verdict_by_bounds": r.verdict,
            "reason": r.verdict_reason,
            "certificate": r.verdict_certificate,
        },
        "critical_probability": r.critical[0] if one else None,
        "sensors": sensors,
        "variance_threshold": {
            "value": as_float(r.variance_threshold),
            "formula": "max(0, 1 - 1/rho(A)^4)",
            "meaning": "finite asymptotic variance of P_t needs lambda above this (Rohr, Marelli and Fu 2010, Theorem 4)",
        }
        if one
        else None,
        "covariance": r.covariance,
        "p_hat": r.p_hat,
        "region": r.region,
        "trace_target": r.trace_target,
        "notes": r.notes(),
    }


def certificate(c: StabilityCertificate) -> dict[str, Any]:
    """A re-checked LMI certificate ``X - L_K(X) > 0`` (Sinopoli et al. 2004, Theorem 5(b))."""
    checked = (
        "X > 0 and X - L_K(X) > 0 decided exactly over the rationals"
        if c.method == "exact_rational"
        else "X > 0 and X - L_K(X) > 0 by NumPy eigenvalues above an explicit rounding allowance"
    )
    return {
        "method": c.method,
        "checked": checked
        + " (Sinopoli et al. 2004, Theorem 5(b); Liu and Goldsmith 2004, Theorem 5(b) for several packets)",
        "gains_from": c.route,
        "at": [str(x) for x in c.lambdas],
        "margin": as_float(c.margin),
        "closed_loop_spectral_radius_at_most": 1.0 - c.margin,
        "solver_margin": as_float(c.solver_margin),
    }


def critical_interval(c: CriticalInterval) -> dict[str, Any]:
    """``lower <= lambda_c <= upper`` for one packet, the others at their probabilities."""
    up = c.upper
    value = None if up.value is None else float(up.value)
    return {
        "lower": {
            "value": as_float(c.lower),
            "formula": "max(0, 1 - 1/(rho(A)^2 prod_{other sensors r} (1 - lambda_r)))",
            "certificate": {
                "method": "closed_form",
                "checked": "rho(A) from numpy.linalg.eigvals; below this value the Lyapunov lower bound "
                "S_bar diverges (Sinopoli et al. 2004, Theorem 3; Liu and Goldsmith 2004, Theorem 3)",
            },
        },
        "upper": {
            "value": value,
            "exact": None if up.value is None else fraction_text(up.value),
            "reason": up.reason,
            "not_certified_at": None if up.lower_end is None else float(up.lower_end),
            "tolerance": c.tolerance,
            "lmi_solves": up.steps,
            "certificate": up.certificate,
        },
        "gap": None if value is None else value - c.lower,
    }


def covariance_bounds(c: CovarianceBounds) -> dict[str, Any]:
    """``S_bar`` (Lyapunov), ``V_bar`` (iteration and SDP) and their ordering."""
    it, d, sdp = c.v_bar, c.sdp_difference, c.sdp
    order = c.ordering_margin
    return {
        "S_bar": {
            "exists": c.s_bar is not None,
            "matrix": _matrix(c.s_bar),
            "trace": _trace(c.s_bar),
            "reason": None
            if c.s_bar is not None
            else "(1 - lambda) rho(A)^2 >= 1 (for several sensors: "
            "prod_s (1 - lambda_s) rho(A)^2 >= 1): the Lyapunov equation has no solution and E[P_t] diverges",
            "method": "scipy.linalg.solve_discrete_lyapunov",
            "residual": as_float(c.s_bar_residual),
        },
        "V_bar": {
            "exists": it.matrix is not None,
            "matrix": _matrix(it.matrix),
            "trace": _trace(it.matrix),
            "reason": it.reason,
            "iteration": {
                "method": "monotone iteration from 0 (Sinopoli et al. 2004, Theorem 6(a)), finished by monotone policy "
                "iteration from above; the two bracket V_bar",
                "iterations": it.iterations,
                "policy_iteration_steps": it.newton_steps,
                "residual": as_float(it.residual),
                "bracket_gap": as_float(it.bracket_gap),
            },
            "sdp": {
                "status": None if sdp is None else sdp.status,
                "matrix": None if sdp is None else _matrix(sdp.matrix),
                "trace": None if sdp is None else _trace(sdp.matrix),
                "reason": c.sdp_reason,
                "relative_difference": as_float(d),
                "agrees": None if d is None else bool(d <= SDP_AGREEMENT),
            },
        },
        "ordering": {
            "S_bar_le_V_bar": None if order is None else bool(order >= -1e-9),
            "min_eigenvalue_of_difference_relative": as_float(order),
        },
        "covariance": "predictor P(t|t-1): S_bar <= lim E[P(t|t-1)] <= V_bar",
        "filtered": c.filtered,
    }


def p_hat_bounds(p: PHatBounds) -> dict[str, Any]:
    """Rohr, Marelli and Fu (2010)'s ``P_hat_N`` for ``N = 1, 2, 4, ...`` and the horizon."""
    t1 = next((_trace(e.matrix) for e in p.entries if e.N == 1), None)
    filtered = p.filtered or (None,) * len(p.entries)
    entries = []
    for e, f in zip(p.entries, filtered):
        t = _trace(e.matrix)
        entries.append(
            {
                "N": e.N,
                "exists": e.matrix is not None,
                "trace": t,
                "improvement_over_P_hat_1_percent": None if t is None or t1 is None else 100 * (1 - t / t1),
                "matrix": _matrix(e.matrix),
                "iterations": e.iterations,
                "started_from_N": e.start,
                "last_step": as_float(e.last_step),
                "reason": e.reason,
                "filtered_trace": _trace(f),
            }
        )
    return {
        "horizon": p.horizon,
        "method": "fixed point of g_N (Rohr, Marelli and Fu 2010, eqs. 11, 15, 22), g_N evaluated level by level on batches",
        "entries": entries,
        "covariance": "predictor P(t|t-1); filtered_trace is the trace of sum_S pi(S) F_S(P_hat_N), an upper "
        "bound of lim sup E[P(t|t)] by the concavity argument of the filtered V_bar",
        "monotone_subsequences_hold": p.subsequences_monotone(),
    }


def region_map(m: RegionMap) -> dict[str, Any]:
    """Liu and Goldsmith (2004), Figs. 4-5: the two-sensor square labelled by the bounds."""
    return {
        "axes": m.axes,
        "values": [float(v) for v in m.values],
        "labels": m.labels,
        "indexing": "labels[i][j] is the cell lambda_1 = values[i], lambda_2 = values[j]",
        "legend": {
            "stable": "the LMI (Liu and Goldsmith 2004, eq. 20) is feasible, by a re-checked certificate at this cell or at a "
            "cell below it in both coordinates (feasibility is monotone, Liu and Goldsmith 2004, Lemma 3)",
            "unstable": "prod_s (1 - lambda_s) rho(A)^2 >= 1: the lower bound diverges",
            "undecided": "neither bound decides",
        },
        "certified_cells": m.certified_cells,
        "lmi_solves": m.lmi_solves,
        "exact": m.exact,
    }


def filtered_bounds(f: FilteredBounds) -> dict[str, Any]:
    """``pi(empty) S_bar <= liminf E[P(t|t)]`` and ``limsup E[P(t|t)] <= sum_S pi(S) F_S(V_bar)``."""
    return {
        "covariance": "filtered P(t|t) = P - P C_S'(C_S P C_S' + R_SS)^-1 C_S P (S_bar and V_bar bound the "
        "predictor P(t|t-1))",
        "lower": {
            "matrix": f.lower,
            "trace": _trace(f.lower),
            "formula": "pi(nothing arrives) * S_bar",
            "why": "F_S(P) >= 0, so E[P(t|t)] >= pi(empty) E[P(t|t-1)] (Sinopoli et al. 2004, Theorem 3 for S_bar)",
        },
        "upper": {
            "matrix": f.upper,
            "trace": _trace(f.upper),
            "formula": "sum_S pi(S) (V_bar - V_bar C_S'(C_S V_bar C_S' + R_SS)^-1 C_S V_bar)",
            "why": "the measurement update F_S is monotone and concave in P and the arrivals at t are "
            "independent of P(t|t-1): Jensen gives E[F_S(P_t)] <= F_S(E P_t) <= F_S(V_bar) "
            "(Sinopoli et al. 2004, Theorem 4 and Lemma 1)",
        },
    }


def trace_target(t: TraceTarget) -> dict[str, Any]:
    """The smallest ``lambda`` with certified ``trace(V_bar) <= target`` (Sinopoli et al. 2004, Theorem 6)."""
    return {
        "target": t.target,
        "smallest_arrival_probability": t.sufficient,
        "bracket": [t.insufficient, t.sufficient],
        "trace_V_bar_at_it": t.trace_at_sufficient,
        "reachable": t.reachable,
        "probes": t.probes,
        "method": "bisection on lambda; trace(V_bar) decreases in lambda (Sinopoli et al. 2004, Theorem 6)",
    }


__all__ = [
    "bounds_report",
    "certificate",
    "covariance_bounds",
    "critical_interval",
    "filtered_bounds",
    "p_hat_bounds",
    "region_map",
    "trace_target",
]
