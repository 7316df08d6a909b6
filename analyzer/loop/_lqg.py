"""Stationary TCP-like LQG gains over lossy links (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V).

With a TCP-like protocol separation holds.  Over i.i.d. links with arrival
probabilities ``lam`` (sensor) and ``nu`` (actuator):

* the control cost-to-go converges to the fixed point of the control MARE
  ``S = A' S A + W - nu A' S B (B' S B + U)^-1 B' S A`` when ``nu`` exceeds
  the critical value ``nu_c`` (``nu_c = 1 - 1/a^2`` for scalar ``a``, ``b != 0``);
  the stationary gain is ``L = (B' S B + U)^-1 B' S A``, ``u = -L x_hat``;
* the expected prediction error covariance converges to the fixed point of the
  estimation MARE ``P = A P A' + Q - lam A P C' (C P C' + R)^-1 C P A'``
  (Sinopoli et al. 2004) above its critical value; kfio uses the stationary
  predictor gain at it, ``K = A P C' (C P C' + R)^-1``.

The optimal estimator is time varying (its gain follows the arrivals); the
stationary gains are what a team deploys, and the loop report analyzes them
exactly.  The fixed points are computed in float64 by value iteration from
0 (monotone: Sinopoli et al. 2004, Theorem 1) and the gains read as the shortest
decimal text of each float, as every float kfio receives.
"""

from __future__ import annotations

import dataclasses
from decimal import Decimal
from fractions import Fraction
from typing import Any

import numpy as np

from ..errors import InvalidInput
from ..model import PerSensorChannel, to_float

#: Value iterations before a MARE is declared divergent.
MAX_ITERATIONS = 20000


def mare_fixed_point(A: np.ndarray, B: np.ndarray, W: np.ndarray, U: np.ndarray, nu: float) -> np.ndarray | None:
    """Fixed point of ``S = A' S A + W - nu A' S B (B' S B + U)^-1 B' S A`` from ``S = 0``; ``None`` if it diverges."""
    S = np.zeros_like(A)
    for _ in range(MAX_ITERATIONS):
        G = B.T @ S @ B + U
        S_next = A.T @ S @ A + W - nu * A.T @ S @ B @ np.linalg.solve(G, B.T @ S @ A)
        S_next = (S_next + S_next.T) / 2
        if not np.all(np.isfinite(S_next)) or np.linalg.norm(S_next) > 1e12:
            return None
        if np.linalg.norm(S_next - S) <= 1e-13 * max(1.0, float(np.linalg.norm(S_next))):
            return S_next
        S = S_next
    return None


def _exact(m: np.ndarray) -> tuple[tuple[Fraction, ...], ...]:
    return tuple(tuple(Fraction(Decimal(repr(float(x)))) for x in row) for row in m)


def lqg_floats(req: Any) -> tuple[np.ndarray, ...]:
    """``A, B, C, Q, R, W, U`` of an LQG loop request as float64 arrays (the data both MAREs read)."""
    return tuple(to_float(m) for m in (req.system.A, req.B, req.system.C, req.system.Q, req.system.R, req.W, req.U))


def with_lqg_gains(req: Any) -> Any:
    """``req`` (a :class:`kfio.loop._model.LoopRequest`) with the stationary TCP-like gains ``K`` and ``L``.

    ``K`` is in predictor form; see the module docstring for both equations.
    """
    if req.protocol != "tcp":
        raise InvalidInput(
            "/controller/lqg",
            "LQG gains are defined here for the TCP-like protocol only (separation fails for UDP-like); "
            "bring fixed gains for a UDP-like loop",
        )
    if req.actuator.model != "bernoulli":
        raise InvalidInput("/actuator_channel", "LQG gains need a Bernoulli actuator channel (the control MARE's nu)")
    if isinstance(req.channel, PerSensorChannel) or req.channel.model != "bernoulli":
        raise InvalidInput("/channel", "LQG gains need one Bernoulli sensor packet (the estimation MARE's lambda)")
    A, B, C, Q, R, W, U = lqg_floats(req)
    nu, lam = float(req.actuator.table[0]), float(req.channel.table[0])
    S = mare_fixed_point(A, B, W, U, nu)
    if S is None:
        raise InvalidInput(
            "/actuator_channel/arrival_probability",
            "the control modified Riccati equation does not converge at this actuator arrival probability "
            "(below its critical value, at least 1 - 1/rho(A)^2): no stationary LQG gain exists",
        )
    P = mare_fixed_point(A.T, C.T, Q, R, lam)
    if P is None:
        raise InvalidInput(
            "/channel/arrival_probability",
            "the estimation modified Riccati equation does not converge at this sensor arrival probability "
            "(Sinopoli et al. 2004): no stationary estimator gain exists",
        )
    L = np.linalg.solve(B.T @ S @ B + U, B.T @ S @ A)
    K = A @ P @ C.T @ np.linalg.inv(C @ P @ C.T + R)
    return dataclasses.replace(req, estimator=_exact(K), feedback=_exact(L), form="predictor")


__all__ = ["control_critical", "mare_fixed_point", "with_lqg_gains"]


def control_critical(req: Any) -> dict[str, Any]:
    """The TCP-like control MARE's critical actuator probability: ``nu_c >= 1 - 1/rho(A)^2``, equality for square invertible ``B``.

    Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V (the dual of the estimation
    bound of Sinopoli et al. 2004, Theorem 3).  Exact text for a scalar plant (``1 - 1/a^2``).
    """
    A, B = to_float(req.system.A), to_float(req.B)
    rho = float(np.max(np.abs(np.linalg.eigvals(A))))
    lower = max(0.0, 1.0 - 1.0 / rho**2) if rho > 0 else 0.0
    exact = None
    if len(req.system.A) == 1:
        a = req.system.A[0][0]
        x = max(Fraction(0), 1 - 1 / a**2) if a else Fraction(0)
        exact = str(x.numerator) if x.denominator == 1 else f"{x.numerator}/{x.denominator}"
    square = B.shape[0] == B.shape[1] and abs(np.linalg.det(B)) > 1e-12 * max(1.0, float(np.abs(B).max()) ** B.shape[0])
    scalar = len(req.system.A) == 1 and req.B[0][0] != 0
    equal = square or scalar
    bracket = _nu_c_bracket(req, lower, exact, bool(equal))
    return {
        "nu_c": bracket,
        "critical_actuator_arrival_probability_lower_bound": lower,
        "critical_actuator_arrival_probability_lower_bound_exact": exact,
        "bound_is_the_critical_value": bool(equal),
        "statement": (
            "the control modified Riccati equation converges iff the actuator arrival probability exceeds "
            + ("1 - 1/rho(A)^2" if equal else "a critical value of at least 1 - 1/rho(A)^2")
        ),
    }


def _text(x: Fraction) -> str:
    return str(x.numerator) if x.denominator == 1 else f"{x.numerator}/{x.denominator}"


def _nu_c_bracket(req: Any, lower: float, exact: str | None, equal: bool) -> dict[str, Any]:
    """``nu_c`` exactly (``1 - 1/rho(A)^2``, square invertible or scalar ``B``) or bracketed.

    The control MARE on ``(A, B, W, U)`` is the estimation MARE of the dual
    system ``(A', B', W, U)`` (Schenato, Sinopoli, Franceschetti, Poolla and
    Sastry 2007, Sec. V), so the certified ``lambda_upper`` of :func:`kfio.bounds`
    on the dual (Sinopoli et al. 2004, Theorem 5, its LMI certificate
    re-checked exactly) is an upper end of the bracket.
    """
    if equal:
        return {
            "lower": lower,
            "upper": lower,
            "exact": exact,
            "is_exact": True,
            "from": "1 - 1/rho(A)^2, the critical value for square invertible or scalar B",
        }
    from .._api import bounds
    from .._system import System
    from ..errors import AnalyzerError

    def tr(m: Any) -> list[list[str]]:
        return [[_text(m[j][i]) for j in range(len(m))] for i in range(len(m[0]))]

    upper: float | None = None
    why = "the certified upper bound of the dual estimation problem (A', B', W, U) from kfio.bounds"
    try:
        dual = System(
            A=tr(req.system.A),
            C=tr(req.B),
            Q=[[_text(x) for x in row] for row in req.W],
            R=[[_text(x) for x in row] for row in req.U],
        )
        rep = bounds(dual, {"model": "bernoulli", "arrival_probability": _text(req.actuator.table[0])}).to_dict()
        upper = rep["critical_probability"]["upper"]["value"]
        if upper is None:
            why = f"no certified upper bound: {rep['critical_probability']['upper'].get('reason')}"
    except AnalyzerError as exc:
        why = f"no certified upper bound: {exc}"
    return {"lower": lower, "upper": upper, "exact": None, "is_exact": False, "from": why}
