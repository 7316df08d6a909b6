"""The second-moment operator of a Markov jump linear system, on half-vectorized symmetric matrices.

With ``Y_i = E[z z' 1{theta = i}]`` (Costa, Fragoso and Marques 2005, Ch. 3),

    Y_j[t+1] = sum_i p_ij (M_i Y_i[t] M_i' + pi_i[t] G_i Sigma G_i'),

so ``T(Y)_j = sum_i p_ij M_i Y_i M_i'`` is a positive linear map on ``N``
symmetric ``d x d`` matrices.  Symmetry makes ``vech`` (the ``d (d + 1) / 2``
entries on and above the diagonal) enough: the matrix of ``T`` has size
``N d (d + 1) / 2`` instead of the ``N d^2`` of ``sum p_ij (M_i kron M_i)`` on
``vec``.  Built exactly over ``Q`` (python-flint ``fmpq_mat``) and, for the
float margin, in numpy from the same formula.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Sequence

import flint
import numpy as np

from ._mjls import Mjls


def vech_index(d: int) -> list[tuple[int, int]]:
    """The ``(row, column)`` of each ``vech`` coordinate, ``row <= column``, row by row."""
    return [(a, b) for a in range(d) for b in range(a, d)]


def _lists(m: flint.fmpq_mat) -> list[list[flint.fmpq]]:
    return [[m[i, j] for j in range(m.ncols())] for i in range(m.nrows())]


def congruence(M: flint.fmpq_mat) -> list[list[flint.fmpq]]:
    """The matrix of ``X -> M X M'`` on ``vech``, exactly: entry ``((a, b), (c, e))``.

    ``(M X M')_ab = sum_ce M_ac X_ce M_be``, and ``X_ce = X_ec`` is one
    coordinate, so an off-diagonal ``(c, e)`` collects ``M_ac M_be + M_ae M_bc``.
    """
    d = M.nrows()
    m = _lists(M)
    idx = vech_index(d)
    out = []
    for a, b in idx:
        ma, mb = m[a], m[b]
        out.append([ma[c] * mb[e] + ma[e] * mb[c] if c != e else ma[c] * mb[c] for c, e in idx])
    return out


def vech(X: flint.fmpq_mat) -> list[flint.fmpq]:
    return [X[a, b] for a, b in vech_index(X.nrows())]


def unvech(v: Sequence[flint.fmpq], d: int) -> flint.fmpq_mat:
    X = flint.fmpq_mat(d, d)
    for (a, b), x in zip(vech_index(d), v):
        X[a, b] = x
        X[b, a] = x
    return X


def _fq(x: Fraction) -> flint.fmpq:
    return flint.fmpq(x.numerator, x.denominator)


def mode_operators(sys: Mjls) -> list[list[list[flint.fmpq]]]:
    """``S_i = sum_b w_b (M_b . M_b')`` on ``vech``, one per reduced mode."""
    cache: dict[int, list[list[flint.fmpq]]] = {}
    out = []
    for branches in sys.branches:
        s = len(vech_index(sys.d))
        acc = [[flint.fmpq(0)] * s for _ in range(s)]
        for br in branches:
            key = id(br.M)
            if key not in cache:
                cache[key] = congruence(br.M)
            S, w = cache[key], _fq(br.weight)
            for r in range(s):
                row, srow = acc[r], S[r]
                for c in range(s):
                    if srow[c]:
                        row[c] += w * srow[c]
        out.append(acc)
    return out


def operator_matrix(sys: Mjls, ops: list[list[list[flint.fmpq]]] | None = None) -> flint.fmpq_mat:
    """The matrix of ``T`` on the stacked ``vech Y_1, ..., vech Y_N``: block ``(j, i)`` is ``p_ij S_i``."""
    ops = ops if ops is not None else mode_operators(sys)
    s = len(vech_index(sys.d))
    N = sys.modes
    T = flint.fmpq_mat(N * s, N * s)
    for i in range(N):
        S = ops[i]
        for j in range(N):
            p = _fq(sys.P[i][j])
            if not p:
                continue
            for r in range(s):
                srow = S[r]
                for c in range(s):
                    if srow[c]:
                        T[j * s + r, i * s + c] = p * srow[c]
    return T


def noise_vector(sys: Mjls) -> flint.fmpq_mat:
    """The stacked ``vech`` of ``sum_i p_ij pi_i sum_b w_b G_b Sigma G_b'``: the forcing of the stationary moments."""
    s = len(vech_index(sys.d))
    N = sys.modes
    per_mode = []
    for i, branches in enumerate(sys.branches):
        acc = flint.fmpq_mat(sys.d, sys.d)
        for br in branches:
            acc += _fq(br.weight) * (br.G * sys.Sigma * br.G.transpose())
        per_mode.append(_fq(sys.pi[i]) * acc)
    out = flint.fmpq_mat(N * s, 1)
    for j in range(N):
        acc = flint.fmpq_mat(sys.d, sys.d)
        for i in range(N):
            if sys.P[i][j]:
                acc += _fq(sys.P[i][j]) * per_mode[i]
        for r, x in enumerate(vech(acc)):
            out[j * s + r, 0] = x
    return out


def apply_exact(sys: Mjls, Y: Sequence[flint.fmpq_mat]) -> list[flint.fmpq_mat]:
    """``T(Y)`` computed from the mode matrices (not from the operator matrix), exactly."""
    out = [flint.fmpq_mat(sys.d, sys.d) for _ in range(sys.modes)]
    for i, branches in enumerate(sys.branches):
        img = flint.fmpq_mat(sys.d, sys.d)
        for br in branches:
            img += _fq(br.weight) * (br.M * Y[i] * br.M.transpose())
        for j in range(sys.modes):
            if sys.P[i][j]:
                out[j] += _fq(sys.P[i][j]) * img
    return out


def second_moments(sys: Mjls, X0: flint.fmpq_mat, dist0: Sequence[Fraction], steps: int) -> list[flint.fmpq_mat]:
    """Exact ``E[z_t z_t']`` for ``t = 0..steps`` from ``z_0`` with second moment ``X0`` and mode law ``dist0``.

    The recursion of the module docstring with the mode law ``pi[t]`` of the
    chain at time ``t`` (not its stationary law).
    """
    Y = [_fq(w) * X0 for w in dist0]
    dist = list(dist0)
    out = []
    for t in range(steps + 1):
        total = flint.fmpq_mat(sys.d, sys.d)
        for X in Y:
            total += X
        out.append(total)
        if t == steps:
            break
        nxt = [flint.fmpq_mat(sys.d, sys.d) for _ in range(sys.modes)]
        for i, branches in enumerate(sys.branches):
            img = flint.fmpq_mat(sys.d, sys.d)
            for br in branches:
                img += _fq(br.weight) * (
                    br.M * Y[i] * br.M.transpose() + _fq(dist[i]) * (br.G * sys.Sigma * br.G.transpose())
                )
            for j in range(sys.modes):
                if sys.P[i][j]:
                    nxt[j] += _fq(sys.P[i][j]) * img
        Y = nxt
        dist = [sum((dist[i] * sys.P[i][j] for i in range(sys.modes)), Fraction(0)) for j in range(sys.modes)]
    return out


def to_numpy(m: flint.fmpq_mat) -> np.ndarray:
    return np.array([[float(m[i, j]) for j in range(m.ncols())] for i in range(m.nrows())], dtype=float).reshape(
        m.nrows(), m.ncols()
    )


def float_operator(sys: Mjls) -> np.ndarray:
    """The matrix of ``T`` on stacked ``vech`` in float64 (for the float margin beside the exact verdict)."""
    d = sys.d
    idx = vech_index(d)
    ra = np.array([a for a, _ in idx])
    rb = np.array([b for _, b in idx])
    s = len(idx)
    N = sys.modes
    T = np.zeros((N * s, N * s))
    for i, branches in enumerate(sys.branches):
        S = np.zeros((s, s))
        for br in branches:
            M = to_numpy(br.M)
            blk = M[ra][:, ra] * M[rb][:, rb] + M[ra][:, rb] * M[rb][:, ra]
            diag = ra == rb
            blk[:, diag] = (M[ra][:, ra] * M[rb][:, rb])[:, diag]
            S += float(br.weight) * blk
        for j in range(N):
            if sys.P[i][j]:
                T[j * s : (j + 1) * s, i * s : (i + 1) * s] = float(sys.P[i][j]) * S
    return T


def spectral_radius(sys: Mjls) -> float:
    """``rho(T)`` in float64 (dense eigenvalues of the ``vech`` matrix)."""
    T = float_operator(sys)
    if T.size == 0:
        return 0.0
    return float(np.max(np.abs(np.linalg.eigvals(T))))


__all__ = [
    "apply_exact",
    "congruence",
    "float_operator",
    "mode_operators",
    "noise_vector",
    "operator_matrix",
    "second_moments",
    "spectral_radius",
    "to_numpy",
    "unvech",
    "vech",
    "vech_index",
]
