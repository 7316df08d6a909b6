r"""The generalized Stein equation of the bounds' search in ``O(n^3)`` work per right-hand side.

Policy evaluation, the certificates' ``X - L_K(X) = I`` and the continuation's stability test
all solve

.. math::

    X - \mathcal L(X) = W, \qquad
    \mathcal L(X) = \sum_i w_i (A + K_i C_i) X (A + K_i C_i)',

one term per arrival pattern (``K_0 = 0`` for the empty one; Sinopoli et al. (2004), Lemma 3;
Liu and Goldsmith (2004), eq. 16).  On ``vech`` this is an ``m x m`` system with ``m = n(n+1)/2``:
``O(n^6)`` work, 820 unknowns at ``n = 40``.  With several terms it is a *generalized* Stein
equation, which the Bartels-Stewart method does not solve directly; but every term is ``A``
plus a low-rank change, so

.. math::

    \mathcal L(X) = c\, A X A' + \sum_{i} w_i \bigl(G_i(X) K_i' + K_i G_i(X)'\bigr),
    \qquad G_i(X) = A X C_i' + \tfrac12 K_i C_i X C_i', \qquad c = \sum_i w_i,

and the equation is one Stein equation ``X - c A X A' = W + (low rank)`` corrected by the
Sherman-Morrison-Woodbury formula over the ``r = n sum_i p_i`` entries of the ``G_i``
(``p_i`` rows of ``C_i``): ``r + 1`` Stein solves with the complex Schur form ``A = Z T Z^H``
(computed once per ``A``; each solve is a column recursion of triangular solves, the
Bartels-Stewart method) and one ``r x r`` system.  The answer is substituted back; if the residual is not
at rounding level (an ill-conditioned ``X - c A X A'``, when two eigenvalues of ``A`` have
``c theta_i theta_j`` near 1) the dense ``vech`` solve answers instead, so the result is always
the one of :func:`solve_dense` up to rounding.  Below :data:`MIN_N` states the dense solve
answers as before.

Status: the solver and its tests are in place, but :func:`kfio.riccati_bounds._riccati.policy_evaluation`,
the certificates and the continuation still solve on ``vech``: at ``n = 40`` (one packet, two
outputs) one solve here takes 27 ms against 62 ms dense, since the ``r + 2`` Stein solves cost
``O(p n^4)``, not the ``O(n^3)`` of a single Stein equation.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import scipy.linalg

from ._vech import congruence_matrix, unvech, vech

#: Below this many states the dense ``vech`` solve is as fast (n = 20: 2.0 ms against 3.1 ms), and it answers.
MIN_N = 30
#: Substitute-back residual allowed, in units of ``n * eps`` times the scale of the terms.
RESIDUAL_FACTOR = 1e4

_SCHUR: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}


def _schur(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    key = A.tobytes()
    hit = _SCHUR.get(key)
    if hit is None:
        if len(_SCHUR) > 16:
            _SCHUR.clear()
        T, Z = scipy.linalg.schur(A, output="complex")
        hit = _SCHUR[key] = (T, Z)
    return hit


def _stein_schur(T: np.ndarray, Z: np.ndarray, c: float, R: np.ndarray) -> np.ndarray:
    """Solve ``X - c A X A' = R_k`` for a batch ``R`` (``b x n x n``), ``A = Z T Z^H``.

    In Schur coordinates ``Y = Z^H X Z`` the equation is ``Y - c T Y T^H = Z^H R Z``; column
    ``j`` of ``T Y T^H`` is ``T sum_{l >= j} Y_l conj(T_jl)``, so the columns are found from
    the last to the first, each by one triangular solve with ``I - c conj(T_jj) T``.
    """
    n = T.shape[0]
    Zh = Z.conj().T
    Rt = (Zh @ R @ Z).transpose(0, 2, 1).copy()  # Rt[b, j] is column j of Z^H R_b Z
    Yt = np.zeros_like(Rt)  # Yt[b, j] is column j of Y_b
    eye = np.eye(n)
    TT = T.T.copy()
    for j in range(n - 1, -1, -1):
        rhs = Rt[:, j]
        if j < n - 1:
            rhs = rhs + c * (T[j, j + 1 :].conj() @ Yt[:, j + 1 :]) @ TT
        M = eye - c * np.conj(T[j, j]) * T
        Yt[:, j] = scipy.linalg.solve_triangular(M, rhs.T, check_finite=False).T
    return (Z @ Yt.transpose(0, 2, 1) @ Zh).real


def _apply(A: np.ndarray, terms: Sequence[tuple[float, np.ndarray]], X: np.ndarray) -> np.ndarray:
    out = np.zeros_like(X)
    for w, M in terms:
        out += w * M @ X @ M.T
    return out


def solve_dense(terms: Sequence[tuple[float, np.ndarray]], rhs: Sequence[np.ndarray]) -> list[np.ndarray] | None:
    """``X - sum_i w_i M_i X M_i' = W`` for each ``W`` in ``rhs`` by one dense ``vech`` solve; ``None`` if singular."""
    n = rhs[0].shape[0]
    L = np.eye(n * (n + 1) // 2)
    for w, M in terms:
        L -= w * congruence_matrix(M)
    try:
        sol = np.linalg.solve(L, np.column_stack([vech(0.5 * (W + W.T)) for W in rhs]))
    except np.linalg.LinAlgError:
        return None
    return [unvech(sol[:, k], n) for k in range(len(rhs))]


def solve_low_rank(
    A: np.ndarray,
    K: Sequence[np.ndarray],
    C: Sequence[np.ndarray],
    weights: Sequence[float],
    rhs: Sequence[np.ndarray],
) -> list[np.ndarray] | None:
    r"""``X - w_0 A X A' - sum_i w_i (A + K_i C_i) X (A + K_i C_i)' = W`` for each ``W`` in ``rhs``.

    By the Sherman-Morrison-Woodbury formula around ``X - c A X A'`` (module docstring);
    ``weights[0]`` is the weight of ``A`` alone, ``weights[i + 1]`` that of ``K[i]``, ``C[i]``.
    Returns ``None`` when the small system is singular or the substituted-back residual is
    not at rounding level; no fallback here (see :func:`solve_stein`).
    """
    A = np.asarray(A, float)
    n = A.shape[0]
    lows = [(float(w), Ki, Ci) for w, Ki, Ci in zip(weights[1:], K, C) if w > 0]
    c = float(weights[0]) + sum(w for w, _, _ in lows)
    T, Z = _schur(A)
    basis = []
    for w, Ki, _ in lows:
        for i in range(n):
            for col in range(Ki.shape[1]):
                E = np.zeros((n, n))
                E[i, :] += w * Ki[:, col]
                E[:, i] += w * Ki[:, col]
                basis.append(E)
    Ws = np.array([0.5 * (W + W.T) for W in rhs])
    batch = np.concatenate([Ws, np.array(basis).reshape(-1, n, n)]) if basis else Ws
    with np.errstate(all="ignore"):
        S = _stein_schur(T, Z, c, batch)
        X0, Xq = S[: len(rhs)], S[len(rhs) :]

        def g(Xs: np.ndarray) -> np.ndarray:
            parts = []
            for _, Ki, Ci in lows:
                XC = Xs @ Ci.T
                parts.append((A @ XC + 0.5 * Ki @ (Ci @ XC)).reshape(len(Xs), -1))
            return np.concatenate(parts, axis=1) if parts else np.zeros((len(Xs), 0))

        if basis:
            H = g(Xq).T  # column q: G(S0^-1(basis_q))
            try:
                coef = np.linalg.solve(np.eye(H.shape[0]) - H, g(X0).T)
            except np.linalg.LinAlgError:
                return None
            X = X0 + np.einsum("qk,qij->kij", coef, Xq)
        else:
            X = X0
        terms = [(float(weights[0]), A)] + [(w, A + Ki @ Ci) for w, Ki, Ci in lows]
        scale = 1.0 + sum(w * np.linalg.norm(M, 2) ** 2 for w, M in terms)
        out = []
        for Xk, W in zip(X, Ws):
            Xk = 0.5 * (Xk + Xk.T)
            res = Xk - _apply(A, terms, Xk) - W
            size = scale * np.linalg.norm(Xk) + np.linalg.norm(W)
            if not np.all(np.isfinite(Xk)) or np.linalg.norm(res) > RESIDUAL_FACTOR * n * np.finfo(float).eps * size:
                return None
            out.append(Xk)
    return out


def solve_stein(
    A: np.ndarray,
    K: Sequence[np.ndarray],
    C: Sequence[np.ndarray],
    weights: Sequence[float],
    rhs: Sequence[np.ndarray],
) -> list[np.ndarray] | None:
    """:func:`solve_low_rank` from :data:`MIN_N` states on; ``None`` below, or where it declines.

    Callers then solve on ``vech`` as before (:func:`solve_dense` is that solve), so below
    :data:`MIN_N` states every float is what it was.
    """
    A = np.asarray(A, float)
    if A.shape[0] < MIN_N:
        return None
    return solve_low_rank(A, K, C, weights, rhs)
