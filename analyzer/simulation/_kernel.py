"""One step of the stochastic Riccati recursion for a batch of covariances.

Rohr, Marelli and Fu (2014), eq. (2) (one packet) and docs/theory.md (a set ``S`` of packets):

.. math::

    \\Phi_S(P) = A P A' + Q - A P C_S' (C_S P C_S' + R_{SS})^{-1} C_S P A',

with ``Phi_0`` (nothing arrived) the open loop ``A P A' + Q``.  Covariances
come as a batch ``(M, n, n)``; ``A``, ``C``, ``Q``, ``R`` are shared.

We never form the gain.  With ``L L' = C_S P C_S' + R_SS`` (Cholesky) and
``V = L^{-1} C_S P`` the correction is ``V' V``, positive semidefinite by
construction, so ``P - V'V`` loses definiteness only through rounding.
``V'V`` is exactly symmetric in floating point (the same products summed in
the same order), and for ``n <= 4`` the open loop is one product with a
symmetrized Kronecker matrix (below), so every step returns an exactly
symmetric batch without a symmetrizing pass.

Per-trajectory arrival sets are handled by *masking*: rows of lost packets
are zeroed in ``C P`` and their block of ``S`` is replaced by the identity,
which makes them contribute exactly nothing.  :class:`GroupedRiccatiStep` is
the alternative (gather the trajectories of each arrival pattern, update with
``C_S``, scatter); ``bench/bench_simulate.py`` measures both.

These batched-matrix kernels are the references: the simulation's default is
:class:`kfio.simulation._packed.PackedRiccatiStep` (the same operations on the
unique entries of ``P``, in cache-sized blocks), tested against them to 1e-12.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

#: A trajectory whose ``trace(P)`` exceeds this is declared diverged: one
#: more step could overflow float64 (products of entries reach ``1e300``).
DIVERGENCE_TRACE = 1e150

#: Largest innovation ratio ``(C P C' + R)_ii / R_ii`` of an arrived row we trust.
#: ``P - V'V`` cancels: in the measured direction the prior variance ``s`` drops
#: to about ``R``, with an absolute rounding error of about ``eps * s``, so the
#: posterior keeps a relative accuracy of ``eps * ratio`` (1e-4 at this bound).
#: Beyond it float64 no longer represents the posterior faithfully (the prior's
#: condition number exceeds what a covariance matrix can carry) and the
#: trajectory is declared diverged rather than continued with garbage.
PRECISION_RATIO = 1e12

#: Up to this many rows the Cholesky factorisation is unrolled over the batch.
_SMALL_P = 4
#: Up to this state dimension the open loop uses the ``n^2 x n^2`` Kronecker form.
_KRON_N = 4


def _whiten(S: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``L^{-1} B`` for ``S = L L'`` (batched Cholesky, ``S`` is ``(M, p, p)``).

    Rows whose ``S`` is not positive definite come back as NaN.
    """
    p = S.shape[-1]
    if p == 1:
        whitened: np.ndarray = B / np.sqrt(S)
        return whitened
    if p > _SMALL_P:
        try:
            return np.linalg.solve(np.linalg.cholesky(S), B)
        except np.linalg.LinAlgError:  # LAPACK refuses the whole batch: find the rows one by one
            V = np.full_like(B, np.nan)
            for m in range(S.shape[0]):
                try:
                    V[m] = np.linalg.solve(np.linalg.cholesky(S[m]), B[m])
                except np.linalg.LinAlgError:
                    pass
            return V
    # Unrolled over p: a handful of whole-batch operations beat a LAPACK call per matrix.
    L = np.zeros_like(S)
    V = np.empty_like(B)
    for j in range(p):
        d = S[:, j, j] - np.einsum("mk,mk->m", L[:, j, :j], L[:, j, :j])
        L[:, j, j] = np.sqrt(d)
        for i in range(j + 1, p):
            L[:, i, j] = (S[:, i, j] - np.einsum("mk,mk->m", L[:, i, :j], L[:, j, :j])) / L[:, j, j]
        V[:, j, :] = (B[:, j, :] - np.einsum("mk,mkn->mn", L[:, j, :j], V[:, :j, :])) / L[:, j, j, None]
    return V


def _lift(S: np.ndarray, floor: np.ndarray) -> np.ndarray:
    """``floor + (S - floor)_+``: the nearest matrix to ``S`` that is ``>= floor``.

    In exact arithmetic ``S = C P C' + R >= R``; when rounding has made ``P``
    indefinite (a prior beyond :data:`PRECISION_RATIO`), this restores it.
    """
    w, U = np.linalg.eigh(S - floor)
    values_out: np.ndarray = floor + np.matmul(U * np.maximum(w, 0.0)[:, None, :], np.swapaxes(U, -1, -2))
    return values_out


def _whiten_safe(S: np.ndarray, B: np.ndarray, floor: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """:func:`_whiten`, retrying rows whose ``S`` lost definiteness with ``_lift(S, floor(rows))``."""
    V = _whiten(S, B)
    bad = ~np.isfinite(V).all(axis=(1, 2)) & np.isfinite(S).all(axis=(1, 2)) & np.isfinite(B).all(axis=(1, 2))
    if bad.any():
        rows = np.flatnonzero(bad)
        V[rows] = _whiten(_lift(S[rows], floor(rows)), B[rows])
    return V


def symmetric_kron(A: np.ndarray) -> np.ndarray:
    """``Ks'`` with ``vec(A X A') = Ks vec(X)`` for symmetric ``X``, rows ``(i,l)`` and ``(l,i)`` equal.

    ``Ks = (K + Pi K) / 2`` where ``K = A (x) A`` and ``Pi`` swaps the output
    index ``(i, l) <-> (l, i)``: for symmetric ``X`` both give ``A X A'``,
    and identical rows make the two entries bitwise equal.  Returned
    transposed, ready for ``vec(X)' Ks'``.
    """
    n = A.shape[0]
    K = np.kron(A, A)
    swap = np.arange(n * n).reshape(n, n).T.reshape(-1)
    return np.ascontiguousarray(((K + K[swap]) / 2).T)


@dataclass(frozen=True, eq=False)
class RiccatiStep:
    """``Phi_S`` for a fixed set of rows that may arrive, applied to batches.

    Build once per system with :meth:`build`; call with a batch ``P`` and an
    optional ``(M, p)`` 0/1 row mask (``None``: every row arrived for every
    trajectory).  With no rows (``p = 0``) it is the open loop ``Phi_0``.
    """

    A: np.ndarray
    Q: np.ndarray
    C: np.ndarray
    R: np.ndarray
    kron_t: np.ndarray | None

    @classmethod
    def build(cls, A: np.ndarray, Q: np.ndarray, C: np.ndarray, R: np.ndarray) -> RiccatiStep:
        kron_t = symmetric_kron(A) if A.shape[0] <= _KRON_N else None
        return cls(A=A, Q=Q, C=C, R=R, kron_t=kron_t)

    def open_loop(self, P: np.ndarray) -> np.ndarray:
        """``Phi_0(P) = A P A' + Q`` for a batch of symmetric ``P``."""
        M, n = P.shape[0], self.A.shape[0]
        out: np.ndarray
        if self.kron_t is not None:
            out = np.matmul(P.reshape(M, 1, n * n), self.kron_t).reshape(M, n, n)
        else:
            out = np.matmul(np.matmul(self.A, P), self.A.T)
            out += np.swapaxes(out, -1, -2)
            out *= 0.5
        out += self.Q
        return out

    def __call__(self, P: np.ndarray, rowmask: np.ndarray | None = None) -> np.ndarray:
        """``Phi_S(P)`` for a batch ``(M, n, n)`` (see :meth:`apply`)."""
        return self.apply(P, rowmask)[0]

    def apply(self, P: np.ndarray, rowmask: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``Phi_S(P)`` and the innovation ratio of each trajectory.

        Parameters
        ----------
        P:
            Batch ``(M, n, n)`` of symmetric positive semidefinite matrices.
        rowmask:
            ``(M, p)`` of 0/1 (which rows arrived), or ``(M, 1)`` when all rows
            of a trajectory arrive or are lost together (one packet); ``None``
            means every row arrived.

        Returns
        -------
        (numpy.ndarray, numpy.ndarray)
            The new batch, and ``max_i (C P C' + R)_ii / R_ii`` over the rows
            that arrived (0 where none did): see :data:`PRECISION_RATIO`.
        """
        post, ratio = self.update(P, rowmask)
        return self.open_loop(post), ratio

    def update(self, P: np.ndarray, rowmask: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The measurement update ``P - V'V`` (the filtered ``P(t|t)``) and the innovation ratios.

        ``V = L^{-1} C_S P`` with ``L L' = C_S P C_S' + R_SS``: the measurement update of
        Sinopoli et al. (2004) for the rows that arrived, in square-root form, so that ``Phi_S(P) = A (P - V'V) A' + Q`` (:meth:`apply`).  Same
        parameters as :meth:`apply`; lost rows contribute nothing, so ``P(t|t) = P`` where nothing arrived.
        """
        p = self.C.shape[0]
        if p == 0:
            return P.copy(), np.zeros(len(P))
        CP = np.einsum("pi,mij->mpj", self.C, P)
        S = np.einsum("mpj,qj->mpq", CP, self.C)
        S += self.R
        ratio = np.einsum("mii->mi", S) / np.diag(self.R)
        if rowmask is not None:
            ratio *= rowmask
        if rowmask is not None and rowmask.shape[1] > 1:
            # Decouple lost rows: their block of S becomes the identity, so that
            # L is block diagonal and zeroing their rows of V removes them exactly.
            S *= rowmask[:, :, None] * rowmask[:, None, :]
            S.reshape(len(S), p * p)[:, :: p + 1] += 1.0 - rowmask
        V = _whiten_safe(S, CP, lambda rows: self._noise_floor(rows, rowmask))
        if rowmask is not None:
            V *= rowmask[:, :, None]
        return P - np.matmul(np.swapaxes(V, -1, -2), V), ratio.max(axis=1)

    def _noise_floor(self, rows: np.ndarray, rowmask: np.ndarray | None) -> np.ndarray:
        """The matrix ``S`` dominates for the given batch rows: ``R``, masked like ``S``."""
        R = np.broadcast_to(self.R, (len(rows),) + self.R.shape).copy()
        if rowmask is not None and rowmask.shape[1] > 1:
            mk = rowmask[rows]
            R *= mk[:, :, None] * mk[:, None, :]
            R.reshape(len(rows), -1)[:, :: self.R.shape[0] + 1] += 1.0 - mk
        return R


@dataclass(frozen=True, eq=False)
class GroupedRiccatiStep:
    """Same map as a masked :class:`RiccatiStep`, by grouping trajectories.

    Each distinct row pattern is updated with its own ``C_S``, ``R_SS``.
    """

    A: np.ndarray
    Q: np.ndarray
    C: np.ndarray
    R: np.ndarray

    def apply(self, P: np.ndarray, rowmask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`RiccatiStep.apply` (``rowmask`` is required)."""
        return self._by_pattern(P, rowmask, "apply")

    def update(self, P: np.ndarray, rowmask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`RiccatiStep.update` (``rowmask`` is required)."""
        return self._by_pattern(P, rowmask, "update")

    def open_loop(self, P: np.ndarray) -> np.ndarray:
        """:meth:`RiccatiStep.open_loop`."""
        return RiccatiStep.build(self.A, self.Q, self.C, self.R).open_loop(P)

    def _by_pattern(self, P: np.ndarray, rowmask: np.ndarray, how: str) -> tuple[np.ndarray, np.ndarray]:
        out, ratio = np.empty_like(P), np.zeros(len(P))
        patterns, inverse = np.unique(rowmask.astype(bool), axis=0, return_inverse=True)
        inverse = inverse.reshape(-1)
        for k, pat in enumerate(patterns):
            idx = np.flatnonzero(inverse == k)
            rows = np.flatnonzero(pat)
            step = RiccatiStep.build(self.A, self.Q, self.C[rows], self.R[np.ix_(rows, rows)])
            out[idx], ratio[idx] = getattr(step, how)(P[idx])
        return out, ratio


def traces(P: np.ndarray) -> np.ndarray:
    """``trace(P_m)`` for a batch."""
    result: np.ndarray = np.einsum("mii->m", P)
    return result


def healthy(P: np.ndarray, tr: np.ndarray) -> np.ndarray:
    """``(M,)`` flags: finite and ``trace(P) <= DIVERGENCE_TRACE``.

    For a positive semidefinite ``P``, ``|P_ij| <= sqrt(P_ii P_jj)``, so a
    bounded finite diagonal bounds every entry; the whole-batch sum catches a
    NaN off the diagonal that rounding might have produced.
    """
    ok = tr <= DIVERGENCE_TRACE  # False for NaN
    if not np.isfinite(P.sum()):
        ok &= np.isfinite(P).all(axis=(1, 2))
    return ok


def _vech_index(n: int) -> np.ndarray:
    """``idx[i, j]``: position of ``P_ij`` (either triangle) in ``vech(P)`` (upper triangle, row by row)."""
    iu, ju = np.triu_indices(n)
    idx = np.empty((n, n), dtype=np.intp)
    idx[iu, ju] = np.arange(len(iu))
    idx[ju, iu] = np.arange(len(iu))
    return idx


def _congruence(A: np.ndarray) -> np.ndarray:
    """``T`` with ``vech(A P A') = T vech(P)``: the formula of :func:`kfio.riccati_bounds._vech.congruence_matrix`.

    Repeated here so that the simulation does not import :mod:`kfio.riccati_bounds` (CVXPY and all) at first use.
    """
    n = A.shape[0]
    iu, ju = np.triu_indices(n)
    W = (A[iu][:, :, None] * A[ju][:, None, :]).reshape(len(iu), n * n)
    T = W[:, iu * n + ju]
    T += W[:, ju * n + iu]
    T[:, iu == ju] *= 0.5
    return np.ascontiguousarray(T)
