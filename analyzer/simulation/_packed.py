"""The default simulation kernel: the Riccati step over a structure of arrays, in cache-sized blocks.

Rohr, Marelli and Fu (2014), eq. (2), for the set ``S`` of rows that arrived, in the order of
:class:`kfio.simulation._kernel.RiccatiStep`:

.. math::

    P^+ = P - V'V, \\quad V = L^{-1} C_S P, \\quad L L' = C_S P C_S' + R_{SS}, \\qquad
    \\Phi_S(P) = A P^+ A' + Q.

``P^+`` is the filtered covariance ``P(t|t)`` of the same arrivals (the
measurement update of Sinopoli et al. (2004)), so the simulation gets its
trace from the same pass.  The measurement update comes first, as in the
matrix kernel: when ``C P C'`` dwarfs ``R`` (innovation ratios up to
:data:`kfio.simulation._kernel.PRECISION_RATIO`) ``P - V'V`` cancels, and
doing the same cancellation as the matrix kernel keeps the two within
``1e-12`` of each other on such trajectories too.

The batch is ``h`` of shape ``(N, M)``, the ``N = n(n+1)/2`` unique entries
of each ``P`` (upper triangle, row by row), one row per entry.  Per block of
columns (trajectories), sized to stay in cache, a step is

1. one GEMM for ``C P`` (``p n`` rows) and ``vech(C P C')`` (``p(p+1)/2`` rows);
2. whole-row arithmetic: the Cholesky factor of ``S = C P C' + R`` unrolled
   over ``p``, ``V = L^{-1} C P`` by forward substitution, and
   ``vech(P - V'V)`` (``2 n`` row products per row of ``C``);
3. one GEMM ``vech(A P^+ A') = T vech(P^+)`` (``T``: the congruence matrix)
   written back into ``h``, plus ``vech(Q)``;

with every temporary preallocated and reused across blocks and steps.  It
also returns what the simulation checks every step: the innovation ratio,
the new trace, whether the block is finite (one reduction per block, a
per-column check only when it is not), and ``trace P(t|t)``.

Safeguards (the same as the matrix kernel): the innovation ratio, rows of
lost packets decoupled by the mask, and trajectories whose ``S`` lost
definiteness (non-finite ``V``) recomputed by
:class:`kfio.simulation._kernel.RiccatiStep` with its lift.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._kernel import RiccatiStep, _congruence, _vech_index

#: Bytes of one block's working set (the GEMM outputs and scratch rows): a few MiB, so that it stays in cache
#: between the GEMMs and the row operations (measured best at n = 3-12 on a 1 MiB L2 / 32 MiB L3 machine).
BLOCK_BYTES = 4 << 20
#: Blocks have at least this many columns per row of ``h``, so that a large congruence matrix (``n >= 20``)
#: is streamed once per many columns rather than once per few.
BLOCK_PER_ROW = 8
#: Block widths are clipped to this range (columns = trajectories).
BLOCK_MIN, BLOCK_MAX = 256, 16384


@dataclass(frozen=True, eq=False)
class StepOutcome:
    """What :meth:`PackedRiccatiStep.advance` returns besides the updated batch (arrays ``(M,)``).

    The arrays belong to the workspace and are overwritten by the next step.
    """

    ratio: np.ndarray  # max innovation ratio (C P C' + R)_ii / R_ii over arrived rows, 0 where none
    trace: np.ndarray  # trace of the new predictor P(t+1|t)
    finite: np.ndarray  # bool: every entry of the new predictor is finite
    filtered_trace: np.ndarray  # trace P(t|t) of the input batch, same arrivals


@dataclass(frozen=True, eq=False)
class PackedRiccatiStep:
    """``Phi_S`` on the packed batch ``(N, M)``: two GEMMs and whole-row arithmetic per cache block.

    Build once per system with :meth:`build`.  :meth:`advance` updates a
    packed batch in place (what :func:`kfio.simulation._simulate.run_monte_carlo`
    calls); :meth:`apply_packed` and :meth:`apply` have the contract of
    :meth:`kfio.simulation._kernel.RiccatiStep.apply` and agree with it to
    rounding (``tests/simulation/test_kernel_packed.py``: 1e-12 relative).
    """

    base: RiccatiStep
    iu: np.ndarray
    ju: np.ndarray
    diag: np.ndarray  # rows of h on the diagonal; row i of the upper triangle starts at diag[i]
    K: np.ndarray  # (p n + p(p+1)/2, N): [vec(C P) by rows k of C; vech(C P C')]
    T: np.ndarray  # (N, N): vech(A P A') = T vech(P)
    q: np.ndarray  # (N, 1): vech(Q)
    r: np.ndarray  # (p(p+1)/2, 1): vech(R)

    @classmethod
    def build(cls, A: np.ndarray, Q: np.ndarray, C: np.ndarray, R: np.ndarray) -> PackedRiccatiStep:
        A, C = np.asarray(A, float), np.asarray(C, float)
        n, p = A.shape[0], C.shape[0]
        iu, ju = np.triu_indices(n)
        N = len(iu)
        idx = _vech_index(n)
        G = np.zeros((p * n, N))
        for k in range(p):
            for j in range(n):
                np.add.at(G[k * n + j], idx[:, j], C[k])  # (C P)_kj = sum_i C_ki P_ij
        ku, lu = np.triu_indices(p)
        H = np.zeros((len(ku), N))
        for a, (k, j) in enumerate(zip(ku.tolist(), lu.tolist())):
            np.add.at(H[a], idx.ravel(), np.outer(C[k], C[j]).ravel())  # sum_ab C_ka P_ab C_jb
        return cls(
            base=RiccatiStep.build(A, Q, C, R),
            iu=iu,
            ju=ju,
            diag=np.flatnonzero(iu == ju),
            K=np.ascontiguousarray(np.concatenate([G, H])),
            T=_congruence(A),
            q=np.asarray(Q, float)[iu, ju][:, None],
            r=np.asarray(R, float)[ku, lu][:, None] if p else np.zeros((0, 1)),
        )

    def __call__(self, P: np.ndarray, rowmask: np.ndarray | None = None) -> np.ndarray:
        return self.apply(P, rowmask)[0]

    def pack(self, P: np.ndarray) -> np.ndarray:
        """``(N, M)`` unique entries of a batch ``(M, n, n)``."""
        return np.ascontiguousarray(P[:, self.iu, self.ju].T)

    def unpack(self, h: np.ndarray) -> np.ndarray:
        """The batch ``(M, n, n)`` of the packed ``h`` (exactly symmetric)."""
        n = self.base.A.shape[0]
        full = np.empty((h.shape[1], n, n))
        full[:, self.iu, self.ju] = h.T
        full[:, self.ju, self.iu] = h.T
        return full

    def mean(self, h: np.ndarray) -> np.ndarray:
        """The sample mean ``(n, n)`` of the batch, without unpacking it: ``unpack(h).mean(axis=0)`` bit for bit.

        NumPy sums ``(M, n, n)`` over its first axis one trajectory after the
        other, ``((P_0 + P_1) + P_2) + ...``, then divides by ``M`` (for ``n = 1``,
        a contiguous row, by pairwise summation).  The same sums run here over
        blocks of columns of ``h`` moved to rows of a small buffer, the running
        sum added to a block's first row before the block is summed.
        """
        return self.means(h)[0]

    def means(self, *hs: np.ndarray) -> list[np.ndarray]:
        """:meth:`mean` of several packed batches of the same size, summed side by side in one pass.

        Each sum is one chain of additions; summing the batches' entries in the same
        rows of the buffer runs their chains together, at one loop step per trajectory.
        """
        N, M = hs[0].shape
        if N == 1:  # (M, 1, 1) is summed as one contiguous row: numpy's pairwise sum
            return [(np.add.reduce(h[0]) / M).reshape(1, 1) for h in hs]
        k = len(hs)
        block = np.empty((min(M, 4096), k * N))
        total = np.empty(k * N)
        for a in range(0, M, len(block)):
            w = min(len(block), M - a)
            for i, h in enumerate(hs):
                np.copyto(block[:w, i * N : (i + 1) * N], h[:, a : a + w].T)
            if a:
                block[0] += total
            np.add.reduce(block[:w], axis=0, out=total)
        mean = total / M
        return [self.unpack(mean[i * N : (i + 1) * N, None])[0] for i in range(k)]

    def traces(self, h: np.ndarray) -> np.ndarray:
        """``trace(P_m)`` from the packed batch (the diagonal rows added in order, as in :meth:`advance`)."""
        out = np.empty(h.shape[1])
        self._diag_sum(h, out)
        return out

    def apply(self, P: np.ndarray, rowmask: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Same contract as :meth:`kfio.simulation._kernel.RiccatiStep.apply` (packs, steps, unpacks)."""
        h, ratio = self.apply_packed(self.pack(P), rowmask)
        return self.unpack(h), ratio

    def apply_packed(self, h: np.ndarray, rowmask: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`apply` on the packed batch ``h`` (``(N, M)``, left unchanged); the new packed batch and the ratios."""
        out = np.array(h, dtype=float, order="C")
        return out, self.advance(out, rowmask).ratio.copy()

    def update_packed(self, h: np.ndarray, rowmask: np.ndarray | None = None) -> np.ndarray:
        """The packed filtered ``vech(P(t|t)) = vech(P - V'V)`` (see :meth:`advance`; ``h`` is left unchanged)."""
        out = np.array(h, dtype=float, order="C")
        work = self.workspace(out.shape[1])
        self.advance(out, rowmask, work, posterior=True)
        return out

    def workspace(self, M: int) -> Workspace:
        """Buffers for :meth:`advance` on batches of ``M`` trajectories (reuse them across steps)."""
        return Workspace.for_step(self, M)

    def advance(
        self, h: np.ndarray, rowmask: np.ndarray | None = None, work: Workspace | None = None, posterior: bool = False
    ) -> StepOutcome:
        """Replace the packed batch ``h`` (C-contiguous ``(N, M)``) by ``Phi_S(h)``, in place.

        Parameters
        ----------
        h:
            Packed predictors ``vech(P_t)``, one column per trajectory; overwritten by ``vech(P_{t+1})``
            (by the filtered ``vech(P(t|t))`` instead if ``posterior``).
        rowmask:
            ``(M, p)`` 0/1 per row, ``(M, 1)`` when all rows arrive together, or ``None`` (all arrived).
        work:
            Buffers from :meth:`workspace` (made here if not given).
        posterior:
            Stop after the measurement update (no open loop).

        Returns
        -------
        StepOutcome
            Innovation ratios, new traces, finiteness flags and ``trace P(t|t)``, as ``(M,)`` arrays.

        Notes
        -----
        Rohr, Marelli and Fu (2014), eq. (2): ``Phi_S(P) = A (P - V'V) A' + Q`` with
        ``V = L^{-1} C_S P`` and ``L L' = C_S P C_S' + R_SS``; ``P - V'V = P(t|t)`` (Sinopoli et al.
        (2004)).  Lost rows are decoupled as in :meth:`kfio.simulation._kernel.RiccatiStep.update`.
        """
        M = h.shape[1]
        if not h.flags.c_contiguous:
            raise ValueError("advance needs a C-contiguous packed batch")
        if work is None or work.M != M:
            work = self.workspace(M)
        mask = None if rowmask is None else np.ascontiguousarray(np.asarray(rowmask, float).T)  # (p or 1, M)
        bad: list[np.ndarray] = []  # global columns for the reference path
        saved: list[np.ndarray] = []  # their input, saved before the block is overwritten
        for a in range(0, M, work.B):
            self._block(h, a, min(a + work.B, M), mask, work, posterior, bad, saved)
        if bad:  # lost definiteness (or non-finite input): the matrix kernel with its lift, on those columns
            cols = np.concatenate(bad)
            rows = None if rowmask is None else np.asarray(rowmask, float)[cols]
            post, work.ratio[cols] = self.base.update(self.unpack(np.concatenate(saved, axis=1)), rows)
            work.ftrace[cols] = np.einsum("mii->m", post)
            h[:, cols] = self.pack(post if posterior else self.base.open_loop(post))
            work.trace[cols] = self.traces(h[:, cols])
            work.finite[cols] = np.isfinite(h[:, cols]).all(axis=0)
        return StepOutcome(work.ratio, work.trace, work.finite, work.ftrace)

    def _block(
        self,
        h: np.ndarray,
        a: int,
        b: int,
        mask: np.ndarray | None,
        work: Workspace,
        posterior: bool,
        bad: list[np.ndarray],
        saved: list[np.ndarray],
    ) -> None:
        """Columns ``a:b``; those whose ``V`` is not finite go to ``bad`` (and their input to ``saved``)."""
        n, p = self.base.A.shape[0], self.base.C.shape[0]
        w = b - a
        hb = h[:, a:b]
        post = work.post[:, :w]
        if p == 0:
            work.ratio[a:b] = 0.0
            np.copyto(post, hb)
        else:
            Y = work.Y[:, :w]
            np.matmul(self.K, hb, out=Y)
            V = Y[: p * n].reshape(p, n, w)  # C P, whitened in place into V = L^-1 C P
            S = Y[p * n :]  # vech(C P C'), rows (k, l) with k <= l
            S += self.r
            mk = None if mask is None else mask[:, a:b]
            if p == 1:
                self._whiten_one(S, V, mk, work.ratio[a:b], work.row[0, :w])
            else:
                self._whiten(S, V, mk, work.ratio[a:b], work, w)
            if not np.isfinite(V.sum()):
                cols = np.flatnonzero(~np.isfinite(V.sum(axis=(0, 1))))
                bad.append(a + cols)
                saved.append(hb[:, cols])  # a copy (fancy index)
            t, u = work.tmp[:n, :w], work.tmp[n:, :w]
            for i, o in enumerate(self.diag.tolist()):  # vech(P - V'V), row i: P_ij - sum_k V_ki V_kj for j >= i
                np.multiply(V[0, i], V[0, i:], out=t[: n - i])
                for k in range(1, p):  # the sum over k first, as the matrix kernel's V'V
                    np.multiply(V[k, i], V[k, i:], out=u[: n - i])
                    t[: n - i] += u[: n - i]
                np.subtract(hb[o : o + n - i], t[: n - i], out=post[o : o + n - i])
        self._diag_sum(post, work.ftrace[a:b])
        if posterior:
            np.copyto(hb, post)
        else:
            np.matmul(self.T, post, out=hb)
            hb += self.q
        self._diag_sum(hb, work.trace[a:b])
        if np.isfinite(hb.sum()):
            work.finite[a:b] = True
        else:
            work.finite[a:b] = np.isfinite(hb).all(axis=0)

    def _whiten_one(
        self, S: np.ndarray, V: np.ndarray, mk: np.ndarray | None, ratio: np.ndarray, s: np.ndarray
    ) -> None:
        """``p = 1``: ``ratio = S / R`` (0 if lost) and ``V <- C P / sqrt(S)`` (0 if lost)."""
        np.divide(S[0], self.base.R[0, 0], out=ratio)
        np.sqrt(S[0], out=s)
        V[0] /= s
        if mk is not None:
            ratio *= mk[0]
            V[0] *= mk[0]

    def _whiten(
        self, S: np.ndarray, V: np.ndarray, mk: np.ndarray | None, ratio: np.ndarray, work: Workspace, w: int
    ) -> None:
        """``p > 1``: the ratio, the mask's decoupling, ``S = L L'`` unrolled and ``V <- L^{-1} V``, over the block.

        The operations of :func:`kfio.simulation._kernel._whiten` (row ``j`` of ``L``, then row ``j`` of
        ``V``), on rows of the block instead of a batch of matrices.
        """
        p, n = V.shape[0], V.shape[1]
        pos = self._positions()
        diagR = np.diag(self.base.R)
        tmp = work.row[0, :w]
        for k in range(p):
            np.divide(S[pos[k, k]], diagR[k], out=tmp)
            if mk is not None:
                tmp *= mk[k if mk.shape[0] > 1 else 0]
            if k == 0:
                np.copyto(ratio, tmp)
            else:
                np.maximum(ratio, tmp, out=ratio)
        if mk is not None and mk.shape[0] > 1:
            # lost rows: their block of S becomes the identity (exactly, for a 0/1 mask)
            for (k, j), x in pos.items():
                np.multiply(mk[k], mk[j], out=tmp)
                S[x] *= tmp
                if k == j:
                    np.subtract(1.0, mk[k], out=tmp)
                    S[x] += tmp
        # Cholesky S = L L', held in place of S: L[i, j] at pos[j, i]
        zt = work.tmp[:n, :w]
        for j in range(p):
            d = S[pos[j, j]]
            for k in range(j):
                np.multiply(S[pos[k, j]], S[pos[k, j]], out=tmp)
                d -= tmp
            np.sqrt(d, out=d)
            for i in range(j + 1, p):
                s = S[pos[j, i]]
                for k in range(j):
                    np.multiply(S[pos[k, i]], S[pos[k, j]], out=tmp)
                    s -= tmp
                s /= d
            for k in range(j):
                np.multiply(S[pos[k, j]], V[k], out=zt)
                V[j] -= zt
            V[j] /= d
        if mk is not None:
            V *= mk[:, None, :] if mk.shape[0] > 1 else mk[None, :, :]

    def _positions(self) -> dict[tuple[int, int], int]:
        """Row of ``vech(C P C')`` holding entry ``(k, l)``, ``k <= l``."""
        ku, lu = np.triu_indices(self.base.C.shape[0])
        return {(int(k), int(j)): x for x, (k, j) in enumerate(zip(ku, lu))}

    def _diag_sum(self, hb: np.ndarray, out: np.ndarray) -> None:
        """``out <- trace`` of each column (diagonal rows added in order)."""
        np.copyto(out, hb[self.diag[0]])
        for d in self.diag[1:]:
            out += hb[d]


@dataclass(frozen=True, eq=False)
class Workspace:
    """Preallocated buffers of :meth:`PackedRiccatiStep.advance` for ``M`` trajectories in blocks of ``B``."""

    M: int
    B: int
    Y: np.ndarray  # (p n + p(p+1)/2, B): C P (whitened in place) and vech(C P C')
    post: np.ndarray  # (N, B): vech(P - V'V)
    tmp: np.ndarray  # (2 n, B): one row of vech(V'V) and a product; or a product of the forward substitution
    row: np.ndarray  # (1, B): scratch row
    ratio: np.ndarray  # (M,)
    trace: np.ndarray  # (M,)
    finite: np.ndarray  # (M,) bool
    ftrace: np.ndarray  # (M,)

    @classmethod
    def for_step(cls, step: PackedRiccatiStep, M: int) -> Workspace:
        rows, N = step.K.shape
        n = step.base.A.shape[0]
        B = int(np.clip(max(BLOCK_BYTES // (8 * (rows + N + 2 * n)), BLOCK_PER_ROW * N), BLOCK_MIN, BLOCK_MAX))
        B = min(B, max(M, 1))
        return cls(
            M=M,
            B=B,
            Y=np.empty((rows, B)),
            post=np.empty((N, B)),
            tmp=np.empty((2 * n, B)),
            row=np.empty((1, B)),
            ratio=np.zeros(M),
            trace=np.empty(M),
            finite=np.empty(M, dtype=bool),
            ftrace=np.empty(M),
        )


__all__ = ["PackedRiccatiStep", "StepOutcome", "Workspace"]
