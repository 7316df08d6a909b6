"""The JSON views of ``kfio simulate``: Monte Carlo bands, exact ``E[P_t]``, the stationary law, outage targets.

Series are arrays (``NaN`` where undefined, ``inf`` where diverged): the encoder
writes both as ``null``.  A matrix that is not finite everywhere is ``null``
as a whole (:func:`kfio.simulation._setup.matrix_or_none`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ..simulation import PERCENTILES, Z95, matrix_or_none
from ._stability import as_float

if TYPE_CHECKING:
    from ..simulation import FiniteHorizonReport, OutageTarget, SimulationReport, StationaryReport


def _first(flags: np.ndarray) -> int | None:
    idx = np.flatnonzero(flags)
    return int(idx[0]) if idx.size else None


def simulation_report(r: SimulationReport) -> dict[str, Any]:
    """``kfio simulate --json``: statistics of ``trace(P_t)`` over the trajectories, per step."""
    low, high = r.ci95
    o = r.options
    return {
        "steps": o.steps,
        "trajectories": o.trajectories,
        "seed": o.seed,
        "initial_channel": o.initial_channel,
        "P0": "Q" if o.P0_is_default else matrix_or_none(o.P0),
        "mean_trace": r.stats.mean,
        "ci95_low": low,
        "ci95_high": high,
        "percentiles": {str(q): r.percentile(q) for q in PERCENTILES},
        "diverged": r.mean_diverged_at is not None,
        "mean_diverged_at": r.mean_diverged_at,
        "percentile_diverged_at": {str(q): _first(~np.isfinite(r.percentile(q))) for q in PERCENTILES},
        "diverged_trajectories": int(r.stats.diverged[-1]),
        "final_mean_covariance": matrix_or_none(r.final_mean_covariance),
        "checks": {
            "arrival_rate": {
                name or "packet": {"observed": float(a), "stationary": float(s)}
                for name, a, s in zip(r.packet_names, r.arrival_rate, r.stationary_arrival_rate)
            },
            "exact_agreement": r.exact_agreement(),
        },
        "exact": r.exact,
        "stationary": r.stationary,
        "covariance": "predictor P(t|t-1): mean_trace, ci95_*, percentiles and final_mean_covariance",
        "filtered": _filtered(r),
        "outage_target": r.outage_target,
    }


def _filtered(r: SimulationReport) -> dict[str, Any] | None:
    f = r.filtered_stats
    if f is None:
        return None
    half = Z95 * f.sem
    return {
        "covariance": "filtered P(t|t) = P - P C_S'(C_S P C_S' + R_SS)^-1 C_S P, from the same arrivals",
        "mean_trace": f.mean,
        "ci95_low": np.maximum(f.mean - half, 0.0),
        "ci95_high": f.mean + half,
        "percentiles": {str(q): f.percentiles[i] for i, q in enumerate(PERCENTILES)},
        "final_mean_covariance": matrix_or_none(r.final_mean_filtered_covariance),
    }


def finite_horizon_report(r: FiniteHorizonReport) -> dict[str, Any]:
    """Exact ``E[P_t]`` over every arrival sequence (Rohr, Marelli and Fu 2014, eq. (7))."""
    growth = r.growth_per_step()
    ftr = r.filtered_mean_trace
    return {
        "steps": r.steps,
        "sequences": r.sequences,
        "initial_channel": r.initial_channel,
        "covariance": "predictor P(t|t-1): mean_trace, final_mean_covariance",
        "mean_trace": r.mean_trace,
        "final_mean_covariance": matrix_or_none(r.mean_covariance[-1]),
        "filtered_mean_trace": ftr,
        "final_filtered_mean_covariance": None
        if r.filtered_mean_covariance is None
        else matrix_or_none(r.filtered_mean_covariance[-1]),
        "diverged": r.diverged_at is not None,
        "diverged_at": r.diverged_at,
        "imprecise_probability": as_float(r.imprecise_probability[-1]),
        "growth_per_step": as_float(growth),
    }


def stationary_report(s: StationaryReport) -> dict[str, Any]:
    """The distribution of ``trace(P_T)`` at the last step: quantiles, outage, tail exponents."""
    return {
        "step": s.step,
        "samples": s.samples,
        "method": "one sample of P_T per trajectory (Kar, Sinopoli and Moura 2012: P_t converges in distribution)",
        "covariance": "predictor P(T|T-1) (quantiles, outage, tail exponent)",
        "quantiles": _quantiles(s.quantiles),
        "filtered_quantiles": _quantiles(s.filtered_quantiles),
        "outage": [{"threshold": m, "probability": p, "ci95": [lo, hi]} for m, p, lo, hi in s.outage],
        "tail_exponent_hill": as_float(s.hill),
        "tail_exponent_hill_ci95": list(s.hill_interval) if s.hill_interval else None,
        "hill_k": s.hill_k,
        "tail_exponent_exact": as_float(s.kappa),
        "tail_exponent_exact_text": s.kappa_exact,
        "exact_mean_growth_per_step": as_float(s.growth_rate),
        "verdict": s.verdict,
        "mean_unreliable": s.mean_unreliable,
        "warnings": s.warnings,
    }


def _quantiles(rows: Any) -> list[dict[str, Any]]:
    return [{"q": q, "trace": as_float(v), "ci95": [as_float(lo), as_float(hi)]} for q, v, lo, hi in rows]


def outage_target(t: OutageTarget) -> dict[str, Any]:
    """The smallest ``lambda`` with estimated ``P(trace P_T > M) <= epsilon`` (label ``estimated``)."""
    return {
        "label": "estimated",
        "threshold": t.threshold,
        "epsilon": t.epsilon,
        "covariance": "predictor P(T|T-1)",
        "method": "bisection over lambda on the stationary outage estimate with common random numbers "
        "(same seed, arrival iff U < lambda), so the estimate and its Wilson 95% interval decrease with lambda",
        "steps": t.steps,
        "trajectories": t.trajectories,
        "seed": t.seed,
        "tolerance": t.tolerance,
        "smallest_arrival_probability_estimate": t.estimate,
        "bracket": {"confidently_insufficient": t.insufficient, "confidently_sufficient": t.sufficient},
        "probes": [{"arrival_probability": lam, "outage": p, "ci95": [lo, hi]} for lam, p, lo, hi in t.probes],
    }


__all__ = ["finite_horizon_report", "outage_target", "simulation_report", "stationary_report"]
