"""Bounds on the optimal TCP-like LQG cost over lossy links (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V).

The derivation (separation holds for TCP-like protocols).  The information
set at time ``t`` holds the measurements that arrived, the sensor arrivals up
to ``t`` and the actuator arrivals up to ``t - 1``; ``x_hat = E[x[t] | I_t]``
is the time-varying Kalman filter with intermittent observations and
``P[t|t]`` its *filtered* error covariance.  With ``S`` the fixed point of the
control modified Riccati equation

    S = A' S A + W - nu A' S B (B' S B + U)^-1 B' S A        (nu > nu_c),

and ``u = -L x_hat``, ``L = (B' S B + U)^-1 B' S A``, completing the square in
the dynamic programming step gives, for the stage cost ``x' W x + nu u' U u``,

    E[x'Wx + nu u'Uu + x[t+1]' S x[t+1] | I_t]
        = E[x' S x | I_t] + tr(S Q) + tr(M P[t|t]),   M = nu A'SB (B'SB + U)^-1 B'SA = A'SA + W - S,

so the stationary average cost of the optimal TCP-like controller is

    J_inf = tr(S Q) + tr(M E[P[t|t]])        (time average of E[P[t|t]]).

``E[P[t|t]]`` has no closed form.  ``M >= 0``, so any Loewner bounds on it
bound ``J_inf``: kfio's certified covariance bounds (:func:`kfio.bounds`)

* lower: ``(1 - lam) S_bar <= liminf E[P[t|t]]``, ``S_bar = (1 - lam) A S_bar A' + Q``
  (Sinopoli et al. 2004, Theorem 3), which gives the paper's ``J_min``;
* upper: ``limsup E[P[t|t]] <= F(X)``, ``F(X) = X - lam X C'(C X C' + R)^-1 C X``,
  for ``X = V_bar``, the estimation MARE's fixed point (the paper's ``J_max``),
  or the tighter ``P_hat_N`` of Rohr, Marelli and Fu (2010); ``F`` is monotone
  and concave, so Jensen's inequality applies.

These bounds are for one Bernoulli sensor packet and a Bernoulli actuator
(the channels for which ``controller.lqg`` computes gains); for other
channels the report says they are not available and why.  They bound the
optimal design, not the stationary gains the loop report analyses exactly
(whose exact cost is at least ``J_inf``; in filter form, the paper's ``J_max``
in the scalar checks).  All of it is float64.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..model import PerSensorChannel, Request, to_float
from ._lqg_types import LqgCostBounds

#: How the bounds are named in the report.
PAPER = "Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V"


def lqg_floats(req: Any) -> tuple[np.ndarray, ...]:
    """``A, B, C, Q, R, W, U`` of an LQG loop request as float64 arrays (the data both MAREs read)."""
    return tuple(to_float(m) for m in (req.system.A, req.B, req.system.C, req.system.Q, req.system.R, req.W, req.U))


def filtered(X: np.ndarray, C: np.ndarray, R: np.ndarray, lam: float) -> np.ndarray:
    """``(1 - lam) X + lam (X - X C'(C X C' + R)^-1 C X)``: the expected measurement update of ``X`` (one packet)."""
    G = C @ X @ C.T + R
    arr: np.ndarray = X - lam * X @ C.T @ np.linalg.solve(G, C @ X)
    return arr


def control_weight(A: np.ndarray, B: np.ndarray, W: np.ndarray, U: np.ndarray, S: np.ndarray, nu: float) -> np.ndarray:
    """``M = nu A'SB (B'SB + U)^-1 B'SA`` (``= A'SA + W - S`` at the fixed point), symmetric and ``>= 0``."""
    M = nu * A.T @ S @ B @ np.linalg.solve(B.T @ S @ B + U, B.T @ S @ A)
    result: np.ndarray = (M + M.T) / 2
    return result


def cost_at(S: np.ndarray, M: np.ndarray, Q: np.ndarray, P_filtered: np.ndarray) -> float:
    """``tr(S Q) + tr(M P)`` for a filtered covariance ``P``."""
    return float(np.trace(S @ Q) + np.trace(M @ P_filtered))


def unavailable(reason: str) -> LqgCostBounds:
    """The bounds' record when they are not available, with the reason."""
    return LqgCostBounds(None, None, None, None, None, reason)


def lqg_cost_bounds(req: Any, S: np.ndarray | None, budget: Any = None) -> LqgCostBounds:
    """``J_min <= J_inf <= J_max`` for the optimal TCP-like controller of ``req`` (module docstring).

    ``req`` is a :class:`kfio.loop.LoopRequest` with ``controller.lqg``; ``S`` the
    control MARE's fixed point at its actuator probability
    (:func:`kfio.loop._lqg.control_fixed_point`), ``None`` when it has none.
    Returns the bounds, what each comes from, the paper's ``J_max`` (from
    ``V_bar``) beside the tighter one, and ``S``.
    """
    if req.protocol != "tcp":
        return unavailable("defined for the TCP-like protocol (separation fails for UDP-like)")
    if isinstance(req.channel, PerSensorChannel) or req.channel.model != "bernoulli":
        return unavailable("kfio's covariance bounds need one Bernoulli sensor packet here")
    if req.actuator.model != "bernoulli":
        return unavailable("the control modified Riccati equation needs a Bernoulli actuator link")
    if S is None:
        return unavailable(
            "the control modified Riccati equation has no fixed point: nu is not above its critical value"
        )
    A, B, C, Q, R, W, U = lqg_floats(req)
    lam, nu = float(req.channel.table[0]), float(req.actuator.table[0])
    M = control_weight(A, B, W, U, S, nu)
    from ..riccati_bounds import compute_bounds

    rep = compute_bounds(Request(system=req.system, channel=req.channel), budget)
    base = float(np.trace(S @ Q))
    lower = upper = paper_upper = None
    lower_from = upper_from = None
    s_bar = rep.covariance.s_bar
    if s_bar is not None:
        lower = cost_at(S, M, Q, (1 - lam) * np.asarray(s_bar, dtype=float))
        lower_from = "(1 - lambda) S_bar <= liminf E[P(t|t)] (Sinopoli et al. 2004, Theorem 3)"
    v_bar = rep.covariance.v_bar.matrix
    if v_bar is not None:
        paper_upper = cost_at(S, M, Q, filtered(np.asarray(v_bar, dtype=float), C, R, lam))
        upper, upper_from = (
            paper_upper,
            "F(V_bar), V_bar the estimation MARE's fixed point (Sinopoli et al. 2004, Theorem 4)",
        )
    for entry in rep.p_hat.entries if rep.p_hat is not None else ():
        if entry.matrix is None or entry.N == 1:
            continue
        j = cost_at(S, M, Q, filtered(np.asarray(entry.matrix, dtype=float), C, R, lam))
        if upper is None or j < upper:
            upper, upper_from = j, f"F(P_hat_{entry.N}) (Rohr, Marelli and Fu 2010)"
    reason = None
    if lower is None:
        reason = "S_bar does not exist: (1 - lambda) rho(A)^2 >= 1, the optimal cost is unbounded"
    elif upper is None:
        reason = "no upper bound: V_bar does not exist at this sensor arrival probability"
    return LqgCostBounds(
        lower=lower,
        upper=upper,
        lower_from=lower_from,
        upper_from=upper_from,
        paper_upper=paper_upper,
        reason=reason,
        tr_S_Q=base,
        S=tuple(tuple(float(x) for x in row) for row in S),
    )


__all__ = ["control_weight", "cost_at", "filtered", "lqg_cost_bounds", "lqg_floats", "unavailable"]
