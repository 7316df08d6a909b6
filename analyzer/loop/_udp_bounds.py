"""Bounds on the critical region of UDP-like loops (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. VI).

Without acknowledgements separation fails and the optimal UDP-like
controller is in general nonlinear; the paper bounds its critical region.
kfio reports bounds it proves here (the paper's own statement is not
reproduced), labelled as bounds, for one Bernoulli sensor packet and a
Bernoulli actuator with ``W > 0`` and ``Q > 0``:

**Outer bound** (necessary for a finite cost of *any* design, TCP-like or
UDP-like, optimal or not):

* ``gamma > gamma_c``, the optimal filter's critical arrival probability
  (Rohr, Marelli and Fu 2014, Theorem 1, decided exactly by
  :func:`kfio.analyze`).  Any controller's information is contained in the
  TCP-like one, under which the applied inputs are known and the conditional
  error covariance is the Kalman filter's ``P[t|t]`` whatever the policy; so
  ``E[x' W x] >= lambda_min(W) tr E[P[t|t]]``, unbounded in time average
  below ``gamma_c`` (``E[P[t|t-1]]`` from ``P_0 = 0`` is nondecreasing).
* ``nu > 1 - 1/rho(A)^2`` (``on_loss: zero``, the paper's model).  A lost actuator packet applies no input and
  ``nu[t]`` is independent of ``x[t]``, so ``E[x x']`` obeys
  ``X[t+1] >= (1 - nu) A X[t] A' + Q`` under any policy, which diverges
  when ``(1 - nu) rho(A)^2 >= 1``.

**Inner bound**: the given gains form a UDP-like admissible policy (a
linear function of the received measurements), so wherever kfio's exact
fixed-gain verdict says *stable* the optimal UDP-like cost is finite: the
exact stable region of the request's gains (``region``, the critical values)
lies inside the optimal UDP-like region, which lies inside the outer bound.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import TYPE_CHECKING

import numpy as np

from .._reporting import ReportPart
from ..model import PerSensorChannel, fraction_text, is_psd, to_float

if TYPE_CHECKING:
    from ._model import LoopRequest
    from ._parts import OptimalFilter


@dataclass(frozen=True)
class UdpOuterBound(ReportPart):
    """The outer bound of the module docstring: necessary arrival probabilities for any design.

    ``sensor_arrival_probability_above`` is the optimal filter's critical value (``None`` with
    ``sensor_note`` when not available); ``actuator_arrival_probability_above`` is
    ``1 - 1/rho(A)^2``, ``None`` with ``on_loss: hold``.
    """

    sensor_arrival_probability_above: float | None
    sensor_arrival_probability_above_exact: str | None
    sensor_note: str | None
    actuator_arrival_probability_above: float | None
    actuator_arrival_probability_above_exact: str | None
    held: bool


@dataclass(frozen=True)
class UdpRegionBounds(ReportPart):
    """Outer and inner bounds on the optimal UDP-like critical region, and where the request lies.

    ``outer`` is ``None`` with a ``reason`` outside the bounds' hypotheses (one Bernoulli sensor
    packet, a Bernoulli actuator, ``W > 0``, ``Q > 0``); ``request_point_inside_optimal_region``
    is ``True`` when the gains are stable at the request, ``False`` when the request lies outside
    the outer bound, else ``None``.
    """

    outer: UdpOuterBound | None
    request_point_inside_optimal_region: bool | None
    reason: str | None


def actuator_outer_bound(req: LoopRequest) -> tuple[float, str | None]:
    """``1 - 1/rho(A)^2`` (``0`` for a stable ``A``), exactly for a scalar plant."""
    A = to_float(req.system.A)
    rho = float(np.max(np.abs(np.linalg.eigvals(A))))
    value = max(0.0, 1.0 - 1.0 / rho**2) if rho > 0 else 0.0
    exact = None
    if req.n == 1:
        a = req.system.A[0][0]
        exact = fraction_text(max(Fraction(0), 1 - 1 / a**2) if a else Fraction(0))
    return value, exact


def udp_region_bounds(req: LoopRequest, optimal_filter: OptimalFilter) -> UdpRegionBounds:
    """The outer and inner bounds of the module docstring for a UDP-like loop request.

    ``optimal_filter`` is the optimal filter's critical value from :func:`kfio.analyze`.
    """
    if (
        isinstance(req.channel, PerSensorChannel)
        or req.channel.model != "bernoulli"
        or req.actuator.model != "bernoulli"
    ):
        return UdpRegionBounds(None, None, "defined for one Bernoulli sensor packet and a Bernoulli actuator link")
    assert req.system.Q is not None  # required by the loop validator
    if not is_psd(req.W, strict=True) or not is_psd(req.system.Q, strict=True):
        return UdpRegionBounds(
            None, None, "the outer bound needs W > 0 and Q > 0 (the cost must see every direction of x)"
        )
    nu_min, nu_min_exact = actuator_outer_bound(req)
    held = req.on_loss == "hold"  # a lost packet then applies the last input: the actuator argument fails
    outer = UdpOuterBound(
        optimal_filter.critical_arrival_probability,
        optimal_filter.critical_arrival_probability_exact,
        optimal_filter.note,
        None if held else nu_min,
        None if held else nu_min_exact,
        held,
    )
    return UdpRegionBounds(outer, None, None)


__all__ = ["UdpOuterBound", "UdpRegionBounds", "actuator_outer_bound", "udp_region_bounds"]
