"""The MARE fixed point ``V_bar`` by continuation in the arrival probability and Newton's method.

Near the critical probability the monotone iteration ``V_{k+1} = g(V_k)`` of
:func:`kfio.riccati_bounds._riccati.solve_v_bar` converges sub-linearly and any
cap on its steps turns "slow" into "divergent".  Newton's method on the MARE
(policy iteration, Kleinman's method for the Riccati equation: evaluate the
gains, re-optimize them) needs no cap: from *any* mean-square stabilizing
gains its iterates decrease monotonically to ``V_bar`` (Sinopoli et al. 2004,
Lemma 1(b) and the proof of Theorem 1) and converge quadratically near it.

Stabilizing gains come from a continuation in the arrival probability: at
``lambda = 1`` the MARE is the classical Riccati equation, whose stabilizing
gains exist iff ``(A, C)`` is detectable; the gains of ``V_bar(x)`` stabilize
at every ``y`` close enough to ``x`` (the spectral radius of the closed-loop
operator is continuous in the probability), so the target is approached from
``x = 1`` by steps that are halved until the previous gains still stabilize.
The answer is the Newton limit at the target, substituted back into the MARE;
when the continuation cannot reach the target (float64 resolution next to the
critical value) the result says so, and it is never read as divergence.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
import scipy.linalg

from .._budget import Budget
from ._riccati import ArrivalModel, gains, mare_residual, one_packet_model, policy_evaluation

#: Relative change of ``X`` at which Newton's iteration has converged (quadratic: a few steps past 1e-8).
NEWTON_RTOL = 1e-14
#: Newton steps at one probability; quadratic convergence needs far fewer, and the residual is checked anyway.
NEWTON_STEPS = 100
#: Relative MARE residual below which a fixed point is accepted.
RESIDUAL_RTOL = 1e-9
#: Smallest continuation step; below it the target is too close to the critical value for float64.
MIN_STEP = 1e-13


@dataclass(frozen=True)
class FixedPoint:
    """The outcome of :func:`mare_fixed_point`.

    Attributes
    ----------
    matrix:
        ``V_bar`` with ``g(V_bar) = V_bar``, or ``None``.
    residual:
        ``||g(V) - V||_F / max(1, ||V||_F)`` of ``matrix``.
    newton_steps:
        Newton (policy-iteration) steps over the whole continuation.
    continuation_points:
        Probabilities at which a fixed point was solved on the way to the target (the target included).
    reason:
        Why ``matrix`` is ``None``.
    """

    matrix: np.ndarray | None
    residual: float | None
    newton_steps: int
    continuation_points: int
    reason: str | None = None


def _newton(model: ArrivalModel, K: Sequence[np.ndarray], budget: Budget | None) -> tuple[np.ndarray | None, int]:
    """Policy iteration from stabilizing gains ``K``: the decreasing Newton sequence and its limit."""
    X = policy_evaluation(model, K)
    if X is None:
        return None, 0
    for step in range(1, NEWTON_STEPS + 1):
        if budget is not None:
            budget.tick("MARE Newton step")
        X_next = policy_evaluation(model, gains(X, model), X)
        if X_next is None:  # rounding at the edge of stability: the last evaluation is the best upper iterate
            return X, step
        done = float(np.linalg.norm(X_next - X)) <= NEWTON_RTOL * float(np.linalg.norm(X_next))
        X = X_next
        if done:
            return X, step
    return X, NEWTON_STEPS


def mare_fixed_point(
    A: np.ndarray,
    C: np.ndarray,
    Q: np.ndarray,
    R: np.ndarray,
    lam: float,
    budget: Budget | None = None,
) -> FixedPoint:
    r"""``V_bar = g_lambda(V_bar)`` for one packet, by continuation from ``lambda = 1`` and Newton's method.

    .. math::

        g_\lambda(X) = A X A' + Q - \lambda A X C' (C X C' + R)^{-1} C X A'

    (Sinopoli et al. 2004, eq. 17).  ``R`` must be positive definite.  The
    control MARE ``S = A'SA + W - nu A'SB (B'SB + U)^-1 B'SA`` of a TCP-like
    loop is this equation for the dual data ``(A', B', W, U, nu)`` (Schenato,
    Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V).

    Returns a :class:`FixedPoint`; ``matrix`` is ``None`` when ``(A, C)`` is not
    detectable (no stabilizing gain at any probability) or when the continuation
    stalls, which happens at or below the critical probability and within float64
    resolution above it: the caller decides which from an exact critical value.
    """
    A, C, Q, R = (np.atleast_2d(np.asarray(x, float)) for x in (A, C, Q, R))
    n, p = A.shape[0], C.shape[0]
    try:
        # any Q > 0 gives the stabilizing gains of lambda = 1: only (A, C) matters for them
        P1 = scipy.linalg.solve_discrete_are(A.T, C.T, np.eye(n), np.eye(p))
    except (np.linalg.LinAlgError, ValueError):
        return FixedPoint(None, None, 0, 0, "(A, C) is not detectable: no gain stabilizes the error at any probability")
    K = gains(P1, one_packet_model(A, C, np.eye(n), np.eye(p), 1.0))
    x, steps, points = 1.0, 0, 0
    while True:
        y = lam
        while policy_evaluation(one_packet_model(A, C, Q, R, y), K) is None:
            if x - y <= MIN_STEP:
                return FixedPoint(
                    None,
                    None,
                    steps,
                    points,
                    f"the continuation stalled at probability {x:.15g}: no stabilizing gain reached {lam:.15g}",
                )
            y = (x + y) / 2
        model = one_packet_model(A, C, Q, R, y)
        X, k = _newton(model, K, budget)
        steps, points = steps + k, points + 1
        if X is None:
            return FixedPoint(None, None, steps, points, "Newton's method lost the stabilizing gains")
        x = y
        if y == lam:
            res = mare_residual(X, model)
            if res > RESIDUAL_RTOL:
                return FixedPoint(
                    None, res, steps, points, f"the fixed point's relative residual {res:.3g} is too large"
                )
            return FixedPoint(X, res, steps, points)
        K = gains(X, model)


__all__ = ["FixedPoint", "mare_fixed_point"]
