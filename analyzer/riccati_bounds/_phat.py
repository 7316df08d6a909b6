"""Rohr, Marelli and Fu (2010)'s sequence of tighter upper bounds ``P_hat_N``.

``g_N(X) = sum over arrival sequences S of length N of P(S) phi(X, S)``
(Rohr, Marelli and Fu (2010), eq. 11), where ``phi`` applies ``Phi_0(X) = A X A' + Q`` (lost) or
``Phi_1(X) = Phi_0(X) - A X C'(C X C' + R)^-1 C X A'`` (arrived) once per step
(eqs. 3-4).  ``P_hat_N`` is the fixed point of ``g_N`` (eq. 15) and

    P_bar <= P_hat_{cN} <= P_hat_N <= P_hat_1 = V_bar      (Theorem 1, eq. 18).

``g_N`` is evaluated level by level: level ``k`` holds the ``2^k`` matrices
``phi(X, S)`` for all prefixes ``S`` of length ``k`` as one array of
half-vectorized matrices (``vech``), so every step is a handful of GEMMs on a
batch instead of ``2^N`` separate recursions.  Two savings: ``Phi_0`` and
``Phi_1`` share ``A X A'``; and the last level needs only weighted sums
because ``Phi_0`` is affine (Rohr, Marelli and Fu (2010), Lemma 1, eq. 7).  The bottom
``CHUNK_LEVELS`` levels are processed in chunks of at most ``2^CHUNK_LEVELS``
matrices, so memory stays bounded (and in cache) whatever ``N`` is.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._budget import Budget
from ..errors import InvalidInput, NumericalFailure
from ._riccati import DIVERGENCE_RATIO, v_bar
from ._small_linalg import cholesky as _cholesky
from ._small_linalg import solve as _solve
from ._vech import congruence_matrix, unvech, vech, vech_layout

#: The batch at the bottom of the tree holds at most ``2**CHUNK_LEVELS`` matrices.
CHUNK_LEVELS = 13
#: :meth:`PHat._descend`'s ``w`` when ``ws`` is given: never read, the weights are then ``ws[k]``.
_NO_WEIGHTS = np.empty(0)

#: Work allowance per application of ``g_N``: ``2^N m^2`` with ``m = n(n+1)/2`` is the cost
#: of the ``A X A'`` GEMMs; the allowance is that of ``N = 20`` at ``n = 4``.
WORK_ALLOWANCE = (1 << 20) * 10 * 10

#: Hard ceiling on ``N`` whatever ``n`` is.
MAX_HORIZON = 20


def max_horizon(n: int) -> int:
    """Largest supported ``N`` for ``n`` states: 20 for ``n <= 4``, fewer above.

    One application of ``g_N`` costs about ``2^N m^2`` multiply-adds with
    ``m = n(n+1)/2`` (about 0.2 s at ``N = 20``, ``n = 4`` here), and the
    fixed point needs some 10-30 applications, so the allowance is that cost.
    Memory is bounded separately by the chunking (:data:`CHUNK_LEVELS`).

    Examples
    --------
    >>> [max_horizon(n) for n in (1, 4, 5, 10, 40)]
    [20, 20, 18, 15, 7]
    """
    m = n * (n + 1) // 2
    N = 1
    while N < MAX_HORIZON and (1 << (N + 1)) * m * m <= WORK_ALLOWANCE:
        N += 1
    return N


class BatchedMare:
    """``Phi_0``, ``Phi_1`` and ``g_N`` on batches of half-vectorized matrices (one packet).

    Parameters
    ----------
    A, C, Q, R:
        The plant (float arrays); ``C`` is ``p x n``.
    lam:
        Arrival probability of the packet.
    """

    def __init__(self, A: np.ndarray, C: np.ndarray, Q: np.ndarray, R: np.ndarray, lam: float) -> None:
        A, C, Q, R = (np.atleast_2d(np.asarray(M, float)) for M in (A, C, Q, R))
        n, p = A.shape[0], C.shape[0]
        iu, ju, dup = vech_layout(n)
        self.n, self.p, self.lam = n, p, float(lam)
        self._iu, self._ju = iu, ju
        # vech(X) @ T gives vech(A X A'), vec(A X C') and vec(C X C') for a batch of rows.
        self._AXA = np.ascontiguousarray(congruence_matrix(A).T)
        self._AXC = np.ascontiguousarray((np.kron(A, C) @ dup).T)
        self._CXC = np.ascontiguousarray((np.kron(C, C) @ dup).T)
        self._q = vech(0.5 * (Q + Q.T))
        self._r = R.ravel().copy()
        self._weights: dict[int, list[np.ndarray]] = {}
        self._wq: dict[int, np.ndarray] = {}

    def correction(self, h: np.ndarray) -> np.ndarray:
        """``vech(A X C'(C X C' + R)^-1 C X A')`` for a batch ``h`` of ``vech(X)`` rows."""
        if self.p == 1:
            G = self._one_output_gain(h)
            products: np.ndarray = G[:, self._iu] * G[:, self._ju]
            return products
        AXC = h @ self._AXC
        S = h @ self._CXC
        S += self._r
        L = _cholesky(S.reshape(-1, self.p, self.p))
        G = _solve(L, AXC.reshape(-1, self.n, self.p).transpose(0, 2, 1))
        values_out: np.ndarray = np.einsum("bki,bki->bi", G[:, :, self._iu], G[:, :, self._ju])
        return values_out

    def _one_output_gain(self, h: np.ndarray) -> np.ndarray:
        """With one output: the rows ``vec(A X C') / sqrt(C X C' + R)`` for a batch ``h`` of ``vech(X)`` (divided in place)."""
        G: np.ndarray = h @ self._AXC
        S = h @ self._CXC
        S += self._r
        np.sqrt(S, out=S)
        G /= S
        return G

    def g_n(self, h: np.ndarray, N: int) -> np.ndarray:
        """``vech(g_N(X))`` for one ``h = vech(X)`` (Rohr, Marelli and Fu (2010), eq. 11)."""
        if N < 1:
            raise InvalidInput("/options/bounds/horizon", "N must be at least 1")
        return self._descend(h[None, :], 0, N, self._tree_weights(N))

    def _tree_weights(self, N: int) -> list[np.ndarray]:
        """``P(S)`` of every prefix ``S`` of length ``k = 0, ..., N - 1``, in the order of the levels.

        They do not depend on ``X``, so they are formed once per ``N`` (by the same products
        ``w (1 - lam)`` and ``w lam`` as the level-by-level recursion, so the same floats).
        """
        ws = self._weights.get(N)
        if ws is None:
            ws = [np.ones(1)]
            for _ in range(N - 1):
                w = ws[-1]
                ws.append(np.concatenate([w * (1.0 - self.lam), w * self.lam]))
            self._weights[N] = ws
            self._wq[N] = ws[-1].sum() * self._q
        return ws

    def _inner_correction(self, level: np.ndarray) -> np.ndarray:
        """:meth:`correction` of a level that only feeds ``Phi_0 - correction`` (elementwise, exact).

        With one output the two gathers are ``ndarray.take`` (cheaper than fancy indexing); the
        products are the same floats, only their memory layout differs, which an elementwise
        subtraction does not see.
        """
        if self.p != 1:
            return self.correction(level)
        G = self._one_output_gain(level)
        c = G.take(self._iu, 1)
        c *= G.take(self._ju, 1)
        return c

    def _last_correction(self, level: np.ndarray) -> np.ndarray:
        """:meth:`correction` of the last level, in the memory layout of fancy indexing.

        The last level is summed by a GEMV, whose order of summation may depend on the layout,
        so the products are laid out as ``G[:, iu] * G[:, ju]`` lays them out (column-major for
        more than one row): gathered along the rows of ``G'`` and transposed back.
        """
        if self.p != 1 or level.shape[0] == 1:
            return self.correction(level)
        G = self._one_output_gain(level)
        Gt = G.T
        c = Gt.take(self._iu, 0)
        c *= Gt.take(self._ju, 0)
        return c.T

    def _descend(
        self, level: np.ndarray, k: int, depth: int, ws: list[np.ndarray] | None, w: np.ndarray = _NO_WEIGHTS
    ) -> np.ndarray:
        """Weighted sum over the ``2^depth`` continuations of the batch ``level``.

        The weights are ``ws[k]`` (the whole level ``k`` of the tree from one root) or, for a
        chunk of a level, ``w`` (then ``ws`` is ``None``).
        """
        lam, m = self.lam, level.shape[1]
        AXA, q, inner = self._AXA, self._q, self._inner_correction
        while depth > 1:
            b = level.shape[0]
            if b > 1 and b << (depth - 1) > 1 << CHUNK_LEVELS:
                w = ws[k] if ws is not None else w
                half = b // 2  # depth first above the chunk size keeps memory bounded
                total: np.ndarray = self._descend(level[:half], k, depth, None, w[:half]) + self._descend(
                    level[half:], k, depth, None, w[half:]
                )
                return total
            nxt = np.empty((2 * b, m))
            phi0 = nxt[:b]
            np.matmul(level, AXA, out=phi0)
            phi0 += q
            np.subtract(phi0, inner(level), out=nxt[b:])
            if ws is None:
                w = np.concatenate([w * (1.0 - lam), w * lam])
            level, k, depth = nxt, k + 1, depth - 1
        # Last step: sum_i w_i [(1-lam) Phi_0(X_i) + lam Phi_1(X_i)]
        #          = (sum_i w_i X_i) A-congruence + (sum_i w_i) Q - lam sum_i w_i corr_i.
        if ws is not None:  # the whole last level: (sum_i w_i) Q was formed with the weights
            w, wq = ws[k], self._wq[len(ws)]
        else:
            wq = w.sum() * q
        result: np.ndarray = (w @ level) @ AXA + wq - lam * (w @ self._last_correction(level))
        return result


@dataclass(frozen=True)
class PHat:
    """One element of Rohr, Marelli and Fu (2010)'s sequence.

    Attributes
    ----------
    N:
        Horizon of ``g_N``.
    matrix:
        The last iterate (``>= P_hat_N`` when started from above), or ``None``
        when the iteration diverged or stalled (then ``reason`` says which).
    iterations:
        Applications of ``g_N`` (0 for ``N = 1``, which is ``V_bar``).
    last_step:
        ``||X_k - X_{k-1}||_max / ||X_k||_max`` at the end.
    start:
        ``N'`` of the ``P_hat_{N'}`` the iteration started from (``N' | N``, so
        ``g_N(P_hat_N') <= P_hat_N'`` and the iterates decrease), or 0 for ``X_0 = 0``.
    reason:
        Why ``matrix`` is ``None``.
    """

    N: int
    matrix: np.ndarray | None
    iterations: int
    last_step: float | None
    start: int
    reason: str | None = None


def _largest_proper_divisor(N: int) -> int:
    return max((d for d in range(1, N // 2 + 1) if N % d == 0), default=1)


def _fixed_point(
    op: BatchedMare, N: int, h0: np.ndarray, start: int, rtol: float, max_iter: int, budget: Budget | None
) -> PHat:
    n = op.n
    h = h0
    cap = DIVERGENCE_RATIO * (1.0 + float(np.abs(op._q).max()))
    step = float("inf")
    what, ticks = f"P_hat_{N}", 1 + (1 << N) // 4096
    with np.errstate(over="ignore", invalid="ignore"):  # divergence is detected just below
        for k in range(1, max_iter + 1):
            if budget is not None:
                budget.tick(what, ticks)
            h_next = op.g_n(h, N)
            top = np.abs(h_next).max()
            if not top <= cap:  # also NaN and infinity
                return PHat(N, None, k, None, start, f"the iteration of g_{N} diverges: P_hat_{N} does not exist here")
            step = float(np.abs(h_next - h).max() / max(1e-300, top))
            h = h_next
            if step <= rtol:
                return PHat(N, unvech(h, n), k, step, start)
    origin = f"from P_hat_{start}" if start else "from 0"
    return PHat(N, None, max_iter, step, start, f"the iteration of g_{N} {origin} did not converge in {max_iter} steps")


def p_hat_sequence(
    A: np.ndarray,
    C: np.ndarray,
    Q: np.ndarray,
    R: np.ndarray,
    lam: float,
    horizons: list[int],
    *,
    rtol: float = 1e-11,
    max_iter: int = 20_000,
    max_iter_from_zero: int = 200,
    budget: Budget | None = None,
) -> dict[int, PHat]:
    """``P_hat_N`` for every ``N`` in ``horizons`` (plus the divisors used as warm starts).

    ``P_hat_1 = V_bar`` (:func:`kfio.riccati_bounds._riccati.v_bar`).  For ``N > 1`` the
    iteration ``X_{k+1} = g_N(X_k)`` (Rohr, Marelli and Fu (2010), eq. 22) starts at
    ``P_hat_d`` for the largest proper divisor ``d`` of ``N``: since
    ``g_N <= g_d^{N/d}`` (Lemma 2, eq. 12), ``g_N(P_hat_d) <= P_hat_d`` and the
    iterates decrease monotonically to ``P_hat_N``, every one of them an
    upper bound of ``P_hat_N`` (eq. 21).  Where ``P_hat_d`` does not exist
    it starts at 0 and increases (proof of Theorem 2), for at most
    ``max_iter_from_zero`` steps: ``P_hat_N`` may exist for large ``N`` where
    ``V_bar`` does not, but near its own threshold that iteration crawls.
    """
    n = np.atleast_2d(A).shape[0]
    out: dict[int, PHat] = {}
    op = BatchedMare(A, C, Q, R, lam)

    def get(N: int) -> PHat:
        if N in out:
            return out[N]
        if N == 1:
            V1 = v_bar(A, C, Q, R, lam)
            out[1] = PHat(1, V1, 0, 0.0, 1, None if V1 is not None else "V_bar does not exist (the MARE diverges)")
            return out[1]
        d = _largest_proper_divisor(N)
        base = get(d)
        if base.matrix is not None:
            out[N] = _fixed_point(op, N, vech(base.matrix), d, rtol, max_iter, budget)
        else:
            out[N] = _fixed_point(op, N, np.zeros(n * (n + 1) // 2), 0, rtol, max_iter_from_zero, budget)
        return out[N]

    for N in sorted(set(horizons)):
        get(N)
    return out


def p_hat(A: np.ndarray, C: np.ndarray, Q: np.ndarray, R: np.ndarray, lam: float, N: int) -> np.ndarray:
    """The ``P_hat_N`` of Rohr, Marelli and Fu (2010): the fixed point of ``g_N`` (eq. 15); ``p_hat(..., 1)`` is ``V_bar``.

    ``V_bar = P_hat_1 >= P_hat_N >= lim E[P_t]`` (their Theorem 1).  The
    algorithm (``g_N`` level by level on batches, warm starts along divisors)
    is :func:`p_hat_sequence`.

    Raises
    ------
    NumericalFailure
        If ``P_hat_N`` does not exist at this ``lam`` (the iteration diverges)
        or the iteration stalls.

    Examples
    --------
    >>> import numpy as np
    >>> A, C, Q, R = np.array([[-1.25]]), np.array([[1.0]]), np.array([[1.0]]), np.array([[2.5]])
    >>> bool(p_hat(A, C, Q, R, 0.4, 8)[0, 0] < p_hat(A, C, Q, R, 0.4, 1)[0, 0])
    True
    """
    if N < 1:
        raise InvalidInput("/options/bounds/horizon", "N must be at least 1")
    res = p_hat_sequence(A, C, Q, R, lam, [N])[N]
    if res.matrix is None:
        raise NumericalFailure(f"P_hat_{N}: {res.reason}")
    return res.matrix
