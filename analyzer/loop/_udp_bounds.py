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

from fractions import Fraction
from typing import Any

import numpy as np

from ..model import PerSensorChannel, is_psd, to_float


def _text(x: Fraction) -> str:
    return str(x.numerator) if x.denominator == 1 else f"{x.numerator}/{x.denominator}"


def actuator_outer_bound(req: Any) -> tuple[float, str | None]:
    """``1 - 1/rho(A)^2`` (``0`` for a stable ``A``), exactly for a scalar plant."""
    A = to_float(req.system.A)
    rho = float(np.max(np.abs(np.linalg.eigvals(A))))
    value = max(0.0, 1.0 - 1.0 / rho**2) if rho > 0 else 0.0
    exact = None
    if req.n == 1:
        a = req.system.A[0][0]
        exact = _text(max(Fraction(0), 1 - 1 / a**2) if a else Fraction(0))
    return value, exact


def udp_region_bounds(req: Any, optimal_filter: tuple[float | None, str | None, str | None]) -> dict[str, Any]:
    """The outer and inner bounds of the module docstring for a UDP-like loop request.

    ``optimal_filter`` is ``(gamma_c, its exact text, why not)`` from :func:`kfio.analyze`.
    """
    out: dict[str, Any] = {
        "kind": "bounds on the critical region of the optimal UDP-like controller, proved in kfio's "
        "documentation (not the paper's Sec. VI statement)",
        "outer": None,
        "inner": "the exact stable region of the given gains (region and critical values above): the optimal "
        "UDP-like cost is finite wherever these gains are mean-square stable",
        "request_point_inside_optimal_region": None,
        "reason": None,
    }
    if (
        isinstance(req.channel, PerSensorChannel)
        or req.channel.model != "bernoulli"
        or req.actuator.model != "bernoulli"
    ):
        out["reason"] = "defined for one Bernoulli sensor packet and a Bernoulli actuator link"
        return out
    assert req.system.Q is not None  # required by the loop validator
    if not is_psd(req.W, strict=True) or not is_psd(req.system.Q, strict=True):
        out["reason"] = "the outer bound needs W > 0 and Q > 0 (the cost must see every direction of x)"
        return out
    gamma_c, gamma_c_exact, why = optimal_filter
    nu_min, nu_min_exact = actuator_outer_bound(req)
    held = req.on_loss == "hold"  # a lost packet then applies the last input: the actuator argument fails
    out["outer"] = {
        "sensor_arrival_probability_above": gamma_c,
        "sensor_arrival_probability_above_exact": gamma_c_exact,
        "sensor_from": "the optimal filter's critical value (Theorem 1, kfio analyze); below it E[P(t|t)] is "
        "unbounded under any controller" + ("" if why is None else f" (not available: {why})"),
        "actuator_arrival_probability_above": None if held else nu_min,
        "actuator_arrival_probability_above_exact": None if held else nu_min_exact,
        "actuator_from": "not available with on_loss: hold (a lost packet applies the last input)"
        if held
        else "1 - 1/rho(A)^2: below it E[x x'] >= (1 - nu) A E[x x'] A' + Q diverges under any controller",
    }
    return out


__all__ = ["actuator_outer_bound", "udp_region_bounds"]
