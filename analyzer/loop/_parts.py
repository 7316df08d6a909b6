"""Typed parts of a loop report: the estimator alone and the optimal filter beside it.

Frozen dataclasses, read as attributes; the JSON of :class:`EstimatorAlone` (with the
optimal filter's fields flattened into it) is built by its view in :mod:`kfio._json`
(the fields and order of ``kfio loop --json``).
"""

from __future__ import annotations

from dataclasses import dataclass

from .._reporting import ReportPart
from .._verdicts import Verdict
from ._critical import Critical


@dataclass(frozen=True)
class OptimalFilter:
    """The optimal time-varying filter's critical arrival probability (Rohr, Marelli and Fu 2014, Theorem 1).

    ``critical_arrival_probability`` and its exact text come from the typed report of
    :func:`kfio.analyze` on the loop's plant and sensor channel; ``note`` says why they are
    missing (a channel other than one Bernoulli packet, or the analysis's error).
    """

    critical_arrival_probability: float | None
    critical_arrival_probability_exact: str | None
    note: str | None


@dataclass(frozen=True)
class EstimatorAlone(ReportPart):
    """The loop's fixed estimator gain without control, beside the optimal filter.

    The estimation error ``e[t+1] = (A - gamma E C) e + w - gamma E v`` (predictor form) is a
    Markov jump linear system; its verdict and stationary ``E[e' e]`` are exact (Costa, Fragoso
    and Marques 2005, Thm 3.9), and ``critical`` is its critical sensor value (one sensor link).
    ``statement`` compares it with the optimal filter's value when both are arrival probabilities.
    """

    verdict: Verdict
    spectral_radius: float
    spectral_radius_exact: str | None
    stationary_error_trace: float | None
    stationary_error_trace_exact: str | None
    critical: Critical | None
    optimal_filter: OptimalFilter
    statement: str | None

    @property
    def critical_sensor_arrival_probability(self) -> float | None:
        """The critical sensor arrival probability of the fixed gain (``None`` for another parameter)."""
        c = self.critical
        return c.value if c is not None and c.parameter.endswith("arrival_probability") else None

    @property
    def critical_sensor_arrival_probability_exact(self) -> str | None:
        c = self.critical
        return c.exact if c is not None and c.parameter.endswith("arrival_probability") else None


__all__ = ["EstimatorAlone", "OptimalFilter"]
