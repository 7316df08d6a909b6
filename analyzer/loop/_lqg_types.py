"""The typed parts of a loop report's ``lqg`` block (their JSON view is in :mod:`kfio._json._loop`).

Two questions, kept apart (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V):

* :class:`LqgOptimal`: the optimal TCP-like controller (time-varying Kalman
  filter, ``u = -L x_hat[t|t]``): when its cost is bounded, and bounds on it;
* :class:`LqgPart`: the stationary gains kfio derived from the two Riccati
  fixed points, which the report's top level analyzes exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

from .._reporting import ReportPart
from ._lqg_critical import ActuatorCritical


@dataclass(frozen=True)
class LqgCostBounds:
    """``lower <= J_inf <= upper`` for the optimal TCP-like cost (:mod:`kfio.loop._lqg_bounds`), or why not.

    ``paper_upper`` is the paper's ``J_max`` (from ``V_bar``), ``upper`` the
    tightest upper bound (``P_hat_N`` of Rohr, Marelli and Fu 2010 when tighter),
    ``S`` the control MARE's fixed point and ``tr_S_Q = tr(S Q)``.
    """

    lower: float | None
    upper: float | None
    lower_from: str | None
    upper_from: str | None
    paper_upper: float | None
    reason: str | None
    tr_S_Q: float | None = None
    S: tuple[tuple[float, ...], ...] | None = None


@dataclass(frozen=True)
class RiccatiSolve:
    """How one modified Riccati fixed point was found (:func:`kfio.riccati_bounds.mare_fixed_point`)."""

    equation: str
    residual: float | None
    newton_steps: int
    continuation_points: int
    trace: float | None


@dataclass(frozen=True)
class LqgOptimal:
    """The optimal TCP-like LQG controller at the request's link probabilities.

    Attributes
    ----------
    verdict:
        ``stable`` when its cost is bounded: the sensor link above the optimal
        filter's critical value (Rohr, Marelli and Fu 2014, Theorem 1) and the
        actuator link above the control MARE's (:class:`ActuatorCritical`);
        ``unstable`` otherwise.
    reasons:
        Why it is unstable (empty when stable).
    critical_sensor, critical_sensor_exact, sensor_note:
        The optimal filter's critical arrival probability (``kfio analyze``), or why it is missing.
    actuator:
        The control MARE's critical actuator arrival probability, exact or bracketed.
    cost_bounds:
        Bounds on its stationary cost.
    statement:
        One sentence: what the optimal controller needs, and what the stationary gains need.
    """

    verdict: str
    reasons: tuple[str, ...]
    critical_sensor: float | None
    critical_sensor_exact: str | None
    sensor_note: str | None
    actuator: ActuatorCritical
    cost_bounds: LqgCostBounds
    statement: str | None = None


@dataclass(frozen=True)
class LqgPart(ReportPart):
    """The ``lqg`` block: the optimal controller, and the stationary gains the top level analyzes.

    ``form`` is the estimator form of the stationary gains (``filter`` by
    default: the optimal controller's structure, ``u = -L x_hat[t|t]``);
    ``gains`` is ``False`` when no stationary gains exist (below the optimal
    critical values), and then the top level has no gains and no cost.
    """

    optimal: LqgOptimal
    form: str
    gains: bool
    control_riccati: RiccatiSolve | None
    estimation_riccati: RiccatiSolve | None


__all__ = ["LqgCostBounds", "LqgOptimal", "LqgPart", "RiccatiSolve"]
