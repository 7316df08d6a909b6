"""Stabilizing gains without an SDP solver: the candidates the certified search re-checks.

Sinopoli et al. (2004)'s Theorem 5 (Sinopoli et al. 2004; Liu and Goldsmith 2004 for
several packets, Liu and Goldsmith (2004)'s Theorem 5) makes three statements equivalent at
an arrival probability ``lambda``: (a) some ``X`` has ``X > g_lambda(X)``,
(b) some gains ``K`` and ``X > 0`` have ``X > L_K(X)`` (plus constants), (c)
the LMI is feasible.  ``lambda_upper`` is where they start to hold.  Any
route to gains ``K`` for (b) is as good as the LMI's ``K = Y^-1 Z``, since
:func:`kfio.riccati_bounds._certificate.certify` re-proves (b) over the rationals
whatever produced ``K``.  Two routes need no solver:

* :func:`annihilating_gains`: when ``C_S`` is injective on the unstable
  invariant subspace ``U`` of ``A``, ``K_S = -A U (C_S U)^+`` gives
  ``(A + K_S C_S) U = 0``; the closed loop is then block triangular and
  ``rho(L_K) < 1`` exactly when ``pi(empty) rho(A)^2 < 1``, so
  ``lambda_upper`` meets the closed-form lower bound (Sinopoli et al. 2004,
  Sec. IV: invertible ``C`` and a single unstable mode are the special
  cases).
* :func:`policy_gains`: the optimal gains of the MARE (``V_bar``'s gains,
  Sinopoli et al. (2004) Lemma 1(a)) refined by policy iteration (Newton's method) from
  gains that already stabilize, with ``Q = I``, ``R = I``: the existence of
  ``V_bar`` does not depend on the choice of ``Q > 0``, ``R > 0``.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import scipy.linalg

from ._riccati import ArrivalModel, gains, policy_evaluation

#: Policy-iteration steps allowed per call (Newton converges quadratically once close).
POLICY_STEPS = 40
#: Relative change of the gains at which policy iteration stops.
GAIN_RTOL = 1e-10


def unstable_subspace(A: np.ndarray) -> np.ndarray:
    """Orthonormal basis ``U`` (``n x k``) of the invariant subspace of the eigenvalues ``|theta| >= 1``.

    From the real Schur form ordered with those eigenvalues first (``k = 0`` when ``A`` is Schur stable).
    """
    A = np.asarray(A, float)
    _, Z, k = scipy.linalg.schur(A, output="real", sort=lambda re, im: re * re + im * im >= 1.0)
    result: np.ndarray = Z[:, :k]
    return result


def annihilating_gains(A: np.ndarray, C_S: Sequence[np.ndarray]) -> tuple[np.ndarray, ...] | None:
    """Gains ``K_S = -A U (C_S U)^+`` with ``(A + K_S C_S) U = 0`` where ``C_S U`` has full column rank.

    Patterns whose ``C_S U`` is rank deficient get the least-squares gain
    (a candidate only; the certificate decides).  ``None`` when ``A`` has no
    eigenvalue on or outside the unit circle.
    """
    U = unstable_subspace(A)
    if U.shape[1] == 0:
        return None
    AU = np.asarray(A, float) @ U
    return tuple(-AU @ np.linalg.pinv(np.asarray(C, float) @ U) for C in C_S)


def normalized_model(A: np.ndarray, C_S: Sequence[np.ndarray], weights: Sequence[float]) -> ArrivalModel:
    """The arrival model with ``Q = I`` and ``R_SS = I``: only ``A``, ``C_S`` and ``pi(S)`` matter here."""
    n = A.shape[0]
    return ArrivalModel(
        np.asarray(A, float), np.eye(n), tuple(C_S), tuple(np.eye(C.shape[0]) for C in C_S), tuple(weights)
    )


def policy_gains(
    model: ArrivalModel, K: Sequence[np.ndarray], steps: int = POLICY_STEPS
) -> tuple[np.ndarray, ...] | None:
    """Policy iteration from stabilizing gains ``K``: evaluate, re-optimize, repeat.

    The evaluations ``X_j = phi(K_j, X_j)`` decrease monotonically to ``V_bar``
    (Sinopoli et al. (2004), Lemma 1(b) and the proof of Theorem 1), and every ``K_j`` is
    mean-square stabilizing.  Returns the last gains whose evaluation
    succeeded (``None`` when ``K`` itself does not stabilize).
    """
    X = policy_evaluation(model, K)
    if X is None:
        return None
    best = tuple(K)
    for _ in range(steps):
        K_next = gains(X, model)
        X_next = policy_evaluation(model, K_next, X)
        if X_next is None:  # rounding at the edge of stability: keep the last stabilizing gains
            break
        best_prev, best = best, K_next
        # the gains, not X, are the product here: X blows up near the threshold while the gains settle
        done = max(float(np.linalg.norm(a - b)) for a, b in zip(K_next, best_prev)) <= GAIN_RTOL * max(
            1.0, max(float(np.linalg.norm(a)) for a in K_next)
        )
        X = X_next
        if done:
            break
    return best
