"""Completing the two-sensor Pareto front from the big flats of one sensor.

With two row groups (sensors) a maximal blind set ``D = Z(u)`` (the slots
whose rows vanish at a kernel vector ``u``) has the blind counts
``(x, y)``: phases of group 0 and of group 1 in ``D``.  Its part
``F = D cap (group 0)`` is a flat of group 0 alone (the zero set of ``u``
in that group), and ``u`` lies in the kernel ``K(F)``.  Hence, for a front
of blind-count vectors and ``B(x)``, the largest ``y'`` of a front vector
with ``x' >= x``, some set beats the front iff for some flat ``F`` of
group 0 a vector of ``K(F)`` zeroes at least ``B(|F|) + 1`` slots of group
1, or the same with the groups exchanged.  Only flats beyond a threshold
need the check: a vector ``(x, y)`` beyond the front lies above a
*minimal beyond point* ``(a, B(a) + 1)``; the points with ``a >= b`` are
checked from group 0 (flats of at least ``min a`` slots), the others from
group 1.  Flats of many slots in a block of few columns are rare, so the
check visits a small part of what the walk over both groups visits
(docs/structure.md gives the numbers).

Flats are those of one group, one per shift orbit (gap-canonical
rotation): a shift moves the phases of both groups together, so it maps
pairs to pairs.  For one flat, "some ``x`` in ``K(F)`` zeroes ``m`` rows of
``P = R K(F)``" (``R`` the other group's rows) is a largest-hyperplane
question in ``dim K(F)`` dimensions, answered exactly by the hyperplanes
spanned by ``dim K(F) - 1`` of the rows when there are few of them, and by
a closure search over the rows of ``P`` otherwise.  A hit is a real blind
set beyond the front: it joins the front and the check starts over, until
a whole pass finds nothing.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from .._budget import Budget
from ._blind import Flat, Margins, SlotSpace, expand, group_space, root
from ._blind_batch import walk


class Front(Protocol):
    """What the proof needs of :class:`kfio.stability._pareto.Front` (which imports this module)."""

    space: SlotSpace
    lower: np.ndarray
    vectors: np.ndarray

    def offer(self, masks: np.ndarray) -> None:
        """Add maximal blind sets whose miss vectors the front does not dominate or equal."""
        ...  # pragma: no cover - protocol


#: Most ``(k - 1)``-subsets of the other group's rows (``C(n, k - 1)``) for which
#: :func:`_hyperplanes` answers; beyond it the closure search over the projected rows does.
_MOST_SUBSETS = 200_000


class _BigFlats:
    """Collector of every flat of one group with at least ``T`` slots, with its kernel."""

    def __init__(self, space: SlotSpace, T: int) -> None:
        self.space = space
        self.T = T
        self.masks: list[np.ndarray] = []
        self.kernels: list[np.ndarray] = []
        self.leaves: list[np.ndarray] = []

    def alive(self, masks: np.ndarray, cores: np.ndarray, kernels: np.ndarray) -> np.ndarray:
        """Flats below a flat with core ``c`` add only slots after ``c``; below a plane, only one parallel class.

        With a 2-dimensional kernel ``K`` every flat below is ``Q`` plus the
        later rows that vanish at one ``u`` in ``K``, i.e. whose projections
        ``r K`` are parallel: at most the largest class of (nearly) parallel
        projections, counted with margin (:func:`_most_parallel`).
        """
        later = (np.arange(self.space.size)[None, :] > cores[:, None]) & ~masks
        held = masks.sum(axis=1)
        ok: np.ndarray = held + later.sum(axis=1) >= self.T
        if kernels.shape[2] == 2 and self.space.rows.shape[1] == 1 and not np.iscomplexobj(self.space.rows):
            W = np.einsum("sk,ckd->csd", self.space.rows[:, 0, :], kernels)
            ok &= held + _most_parallel(W, later, self.space.tol) >= self.T
        return ok

    def alive_hulls(self, hulls: np.ndarray) -> np.ndarray:
        return hulls.sum(axis=1) >= self.T

    def visit(self, masks: np.ndarray, kernels: np.ndarray) -> None:
        if kernels.shape[2] == 0:
            return  # full rank: not blind
        for i in np.flatnonzero(masks.sum(axis=1) >= self.T):
            self.masks.append(masks[i].copy())
            self.kernels.append(kernels[i])

    def offer(self, masks: np.ndarray) -> None:
        for m in masks[masks.sum(axis=1) >= self.T]:
            self.leaves.append(m.copy())


#: Projections shorter than this many tolerances count as parallel to every other.
_SHORT = 1e4


def _most_parallel(W: np.ndarray, rows: np.ndarray, tol: float) -> np.ndarray:
    """Per batch row, an upper bound on the most ``rows`` whose real 2-vectors ``W`` are parallel.

    Two rows count as parallel for the closure when one leaves a residual
    ``|W_t| |sin(angle)| <= tol`` against the other; a row with
    ``|W_t| >= _SHORT tol`` is then within ``1 / _SHORT`` radians of the
    class direction, so every class fits in a window of ``2 / _SHORT``
    radians of angles (taken modulo pi); shorter rows are counted in every
    class.
    """
    size = np.linalg.norm(W, axis=2)
    short = rows & (size < _SHORT * tol)
    counted = rows & ~short
    angle = np.where(counted, np.arctan2(W[..., 1], W[..., 0]) % np.pi, 8.0)  # 8 > 2 pi: a row not counted
    angle = np.sort(np.concatenate([angle, angle + np.pi], axis=1), axis=1)
    # One searchsorted for all batch rows: row c lives in [16 c, 16 c + 16).
    keys = (angle + 16.0 * np.arange(angle.shape[0])[:, None]).ravel()
    ends = np.searchsorted(keys, keys + 2.0 / _SHORT, side="right").reshape(angle.shape)
    inside = ends - np.arange(angle.size).reshape(angle.shape)
    inside[angle >= 8.0] = 0
    return np.asarray(inside.max(axis=1, initial=0) + short.sum(axis=1))


def big_flats(space: SlotSpace, T: int, budget: Budget, margins: Margins) -> list[tuple[np.ndarray, np.ndarray | None]]:
    """Every blind flat of a one-group space with at least ``T`` slots, one per shift orbit.

    The batched closure walk of :func:`kfio.stability._blind_batch.walk`
    (gap-canonical rotation), cutting every subtree whose hull holds fewer
    than ``T`` slots.  Expanded flats come with an orthonormal kernel basis;
    maximal ones (``None``) get theirs when they are checked, most never are.
    """
    found = _BigFlats(space, T)
    walk(space, budget, margins, found)
    out: list[tuple[np.ndarray, np.ndarray | None]] = list(zip(found.masks, found.kernels))
    seen = {m.tobytes() for m in found.masks}
    for m in found.leaves:
        if m.tobytes() not in seen:
            seen.add(m.tobytes())
            out.append((m, None))
    return out


def _kernel(M: np.ndarray, margins: Margins) -> np.ndarray:
    """Orthonormal basis (columns) of the null space of ``M``."""
    L = M.shape[1]
    if M.shape[0] == 0:
        return np.eye(L, dtype=M.dtype)
    _, sv, vh = np.linalg.svd(M)
    rank = int((~margins.record(sv)).sum())
    return np.asarray(vh[rank:].conj().T)


def most_zeros_vector(P: np.ndarray, m: int, budget: Budget, margins: Margins) -> np.ndarray | None:
    """A unit ``x`` at which at least ``m`` slots of ``P`` (``N x p x k``) vanish, or ``None`` if there is none.

    Slots vanishing on all of ``C^k`` count everywhere.  With one row per
    slot, the best ``x`` is a normal of a hyperplane spanned by ``k - 1``
    independent rows (a larger set of rows in a hyperplane can be completed
    to one so spanned, unless every row lies in one hyperplane), so these
    hyperplanes are counted exhaustively when there are at most
    :data:`_MOST_SUBSETS`; otherwise (and with several rows per slot) a
    closure search over the flats of ``P`` with at least ``m`` slots answers.
    """
    N, p, k = P.shape
    zero = margins.record(np.linalg.norm(P.reshape(N, -1), axis=1))
    need = m - int(zero.sum())
    e0 = np.zeros(k, dtype=P.dtype)
    e0[0] = 1
    if need <= 0:
        return e0
    if k == 1:
        return None
    rows = P[~zero]
    if rows.shape[0] < need:
        return None
    if p == 1 and math.comb(rows.shape[0], k - 1) <= _MOST_SUBSETS:
        return _hyperplanes(rows[:, 0, :], need, budget, margins)
    return _closure_hit(P, m, budget, margins)


def _hyperplanes(R: np.ndarray, need: int, budget: Budget, margins: Margins) -> np.ndarray | None:
    """A normal ``x`` of a hyperplane holding ``need`` of the (non-zero) rows of ``R``, or ``None``.

    Every hyperplane spanned by ``k - 1`` independent rows is reached once
    as an increasing sequence of rows, each outside the span of the rows
    before it.  The walk keeps, per prefix, an orthonormal basis ``N`` of
    the vectors its rows annihilate and shrinks it by one Householder
    reflection per added row (``R_e N`` is reflected onto the first axis;
    the other columns stay), so the ``C(n, k - 1)`` normals cost a few
    elementwise operations each; one product then counts the rows on each
    hyperplane.
    """
    n, k = R.shape
    if need <= k - 1:
        return _kernel(R[: k - 1], margins)[:, 0]
    whole = _kernel(R, margins)
    if whole.shape[1] > 0:
        return whole[:, 0]
    last = np.full(1, -1)
    N = np.eye(k, dtype=R.dtype)[None, :, :]
    index = np.arange(n)
    for _ in range(k - 1):
        budget.tick("sigma: front proof", max(1, last.size * n // 4096))
        W = np.matmul(R, N)
        size = np.sqrt((W * W.conj()).real.sum(axis=2))
        spanned = margins.record(size)
        # Reach each hyperplane H by its greedy basis (s_1 = its first row, each next
        # one its first row outside the span so far): then every row of H up to
        # the last s lies in that span, so H holds at most the spanned rows plus
        # the rows after the last s.
        alive = spanned.sum(axis=1) + (n - 1 - last) >= need
        if N.shape[2] == 2 and not np.iscomplexobj(R):
            # The hyperplanes through a prefix with a plane of normals hold its
            # span plus one class of parallel projections: count the largest.
            alive &= spanned.sum(axis=1) + _most_parallel(W, ~spanned, margins.tol) >= need
        later = alive[:, None] & (index[None, :] > last[:, None]) & ~spanned
        b, e = np.nonzero(later)
        N, last = _reflect_out(N[b], W[b, e] / size[b, e][:, None]), e
    on = margins.record(np.abs(N[:, :, 0] @ R.T)).sum(axis=1)
    best = np.flatnonzero(on >= need)
    return np.asarray(N[best[0], :, 0]) if best.size else None


def _reflect_out(N: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Per row, an orthonormal basis of ``{N y : w . y = 0}`` (``N``: ``(C, k, d)`` orthonormal, ``w``: unit ``(C, d)``).

    The Householder reflection ``H = I - 2 v v^* / |v|^2``, ``v = conj(w) + s e_1``
    (``s`` of the modulus one and phase of ``conj(w_1)``, so nothing cancels),
    maps ``conj(w)`` to a multiple of ``e_1``; its other columns are
    orthonormal and annihilated by ``w``.
    """
    u = w.conj()
    first = u[:, 0]
    phase = np.where(np.abs(first) > 0, first / np.maximum(np.abs(first), 1e-300), 1.0)
    v = u.copy()
    v[:, 0] += phase
    scale = 2.0 / np.einsum("cd,cd->c", v.conj(), v).real
    d = N.shape[2]
    H = (
        np.eye(d, dtype=np.result_type(N, w))[None, :, 1:]
        - scale[:, None, None] * v[:, :, None] * v[:, None, 1:].conj()
    )
    return np.asarray(np.matmul(N, H))


def _closure_hit(P: np.ndarray, m: int, budget: Budget, margins: Margins) -> np.ndarray | None:
    """Depth-first closure search over the flats of ``P`` (no symmetry) for one with ``m`` slots."""
    N, p, k = P.shape
    space = SlotSpace(n_phases=N, n_groups=1, rows=P, tol=margins.tol)
    stack = [root(space, margins)]
    while stack:
        flat = stack.pop()
        budget.tick("sigma: front proof")
        exp = expand(space, flat, margins)
        if exp.kernel.shape[1] == 0:
            continue
        if exp.mask.sum() >= m:
            return np.asarray(exp.kernel[:, 0])
        for c in np.flatnonzero(exp.hulls.sum(axis=1) >= m)[::-1]:
            child = Flat(exp.masks[c], int(exp.cores[c]), exp.kernel, exp.cuts[c], int(exp.cut_ranks[c]))
            if exp.dims[c] == 1:
                if exp.masks[c].sum() >= m:
                    return np.asarray(child.kernel()[:, 0])
                continue
            stack.append(child)
    return None


def maximal_zero_set(space: SlotSpace, u: np.ndarray, margins: Margins) -> np.ndarray:
    """A maximal blind set holding ``Z(u)``: add slots one at a time, closing after each, until the kernel is a line."""
    mask = margins.record(np.linalg.norm(space.rows @ u, axis=1))
    while True:
        K = _kernel(space.rows[mask].reshape(-1, space.n_columns), margins)
        if K.shape[1] <= 1:
            return mask
        W = space.rows @ K
        ranks = (~margins.record(np.linalg.svd(W, compute_uv=False))).sum(axis=1)
        grow = np.flatnonzero(~mask & (ranks < K.shape[1]))
        if grow.size == 0:
            return mask  # every other slot kills the whole kernel: already maximal
        s = int(grow[0])
        # ker(W_s) within K: close over every slot vanishing on it.
        K2 = K @ _kernel(W[s], margins)
        mask = margins.record(np.linalg.norm(space.rows @ K2, axis=(1, 2)))


def _blind_counts(front: Front, side: int) -> list[tuple[int, int]]:
    """Front vectors as blind counts ``(group side, other group)``."""
    n = front.space.n_phases
    return [(n - int(z[side]), n - int(z[1 - side])) for z in front.vectors]


def _beyond_floor(counts: list[tuple[int, int]], a: int) -> int:
    """``B(a)``: the largest other-group count of a front vector holding ``>= a`` of this group (-1: none)."""
    return max((y for x, y in counts if x >= a), default=-1)


def threshold(front: Front, side: int, most: tuple[int, int]) -> int | None:
    """Fewest slots of group ``side`` in a flat that must be checked (``None``: no check needed).

    ``most``: the largest blind set of each group alone, which bounds both
    counts.  A point ``(a, B(a) + 1)`` beyond the front is checked from
    group 0 when ``a >= b`` and from group 1 when ``a > b`` (in that group's
    order), so every point is checked from one side.
    """
    counts = _blind_counts(front, side)
    own, other = most[side], most[1 - side]
    best = None
    for a in range(own + 1):
        b = _beyond_floor(counts, a) + 1
        if b <= other and (a > b or (a == b and side == 0)):
            best = a if best is None else min(best, a)
    return best


def prove_front(space: SlotSpace, front: Front, budget: Budget, margins: Margins) -> int:
    """Add to ``front`` until no maximal blind set of a two-group ``space`` beats it; returns the flats checked.

    See the module docstring for why a pass without a hit proves the
    front.  Flats are checked largest first, and a hit is pushed to the
    most slots of the other group that ``K(F)`` can zero, so the front, and
    with it the thresholds, rise early.  Thresholds only rise as the front
    grows (a point ``(a, B(a) + 1)`` with ``a >= B(a) + 1`` stays one for a
    larger ``B``), so a flat that held no vector beyond the front keeps
    holding none: each is checked once.  When the rows of group 1 are those
    of group 0 times one invertible matrix (:func:`shared_matroid`), both
    groups have the same flats and one walk serves both.  Raises
    :class:`~kfio.errors.BudgetExceeded` when ``budget`` runs out.
    """
    n = space.n_phases
    most = (n - int(front.lower[0]), n - int(front.lower[1]))
    groups = [group_space(space, g) for g in (0, 1)]
    M = shared_matroid(groups[0], groups[1], margins)
    walked: dict[int, tuple[int, list[tuple[np.ndarray, np.ndarray | None]]]] = {}
    passed: dict[int, set[bytes]] = {0: set(), 1: set()}
    checked = 0

    def flats(side: int, T: int) -> list[tuple[np.ndarray, np.ndarray | None]]:
        source = 0 if M is not None else side
        if source not in walked or walked[source][0] > T:
            want = T
            if M is not None:
                want = min(T, *(t for t in (threshold(front, g, most) for g in (0, 1)) if t is not None))
            found = big_flats(groups[source], want, budget, margins)
            found.sort(key=lambda f: -int(f[0].sum()))
            walked[source] = (want, found)
            if M is not None or len(walked) == 2:
                seed_generic(space, front, groups, [walked[0 if M is not None else g][1] for g in (0, 1)], margins)
        if side == source:
            return walked[source][1]
        return [(mask, None) for mask, _ in walked[source][1]]  # same flats; kernels from this group's rows

    while True:
        hits = 0
        for side in (0, 1):
            T = threshold(front, side, most)
            if T is None:
                continue
            new, n_checked = _check(space, front, side, flats(side, T), groups, passed[side], most, budget, margins)
            hits += new
            checked += n_checked
        if hits == 0:
            return checked


def seed_generic(
    space: SlotSpace,
    front: Front,
    groups: list[SlotSpace],
    flats: list[list[tuple[np.ndarray, np.ndarray | None]]],
    margins: Margins,
) -> None:
    """Offer the *generic front*: for ``r_0 + r_1 = L - 1``, the largest known flats of those ranks share a kernel vector.

    Flats ``F_0`` of group 0 and ``F_1`` of group 1 with ranks ``r_0 + r_1 =
    L - 1`` have kernels of dimensions ``L - r_0`` and ``L - r_1``, which sum
    to ``L + 1``: they meet, and a common kernel vector zeroes both, so the
    blind counts ``(|F_0|, |F_1|)`` are attained whatever the rows.  From the
    largest flat of each rank among ``flats`` (maximal flats, with no kernel
    basis given, have rank ``L - 1``), so the proof starts from thresholds
    near their final values.
    """
    L = space.n_columns
    largest: list[dict[int, np.ndarray]] = [{}, {}]
    for g in (0, 1):
        for mask, K in flats[g]:
            r = L - 1 if K is None else L - K.shape[1]
            if r not in largest[g] or mask.sum() > largest[g][r].sum():
                largest[g][r] = mask
    for r, F0 in largest[0].items():
        F1 = largest[1].get(L - 1 - r)
        if F1 is None:
            continue
        K0 = _kernel(groups[0].rows[F0].reshape(-1, L), margins)
        K1 = _kernel(groups[1].rows[F1].reshape(-1, L), margins)
        both = _kernel(np.concatenate([K0, -K1], axis=1), margins)
        if both.shape[1] == 0:
            continue  # the rank calls of the walk and of this factorization disagree: offer nothing
        u = K0 @ both[: K0.shape[1], 0]
        front.offer(maximal_zero_set(space, u / np.linalg.norm(u), margins)[None, :])


def shared_matroid(a: SlotSpace, b: SlotSpace, margins: Margins) -> np.ndarray | None:
    """An invertible ``M`` with ``rows_b = rows_a M`` for every slot (then both have the same flats), or ``None``.

    In eigen-coordinates a group's rows are ``c_g diag(omega^n)``: with one
    row per group and no zero entry, ``M = diag(c_1 / c_0)``, a column
    scaling, which changes no rank.  Found by least squares and accepted
    only when it reproduces every row to within the rank tolerance.
    """
    if a.rows.shape != b.rows.shape:
        return None
    A = a.rows.reshape(-1, a.n_columns)
    B = b.rows.reshape(-1, b.n_columns)
    if np.linalg.matrix_rank(A) < a.n_columns:
        return None
    M = np.linalg.lstsq(A, B, rcond=None)[0]
    if np.abs(A @ M - B).max() > margins.tol or np.linalg.svd(M, compute_uv=False)[-1] <= margins.tol:
        return None
    return np.asarray(M)


def _check(
    space: SlotSpace,
    front: Front,
    side: int,
    flats: list[tuple[np.ndarray, np.ndarray | None]],
    groups: list[SlotSpace],
    passed: set[bytes],
    most: tuple[int, int],
    budget: Budget,
    margins: Margins,
) -> tuple[int, int]:
    """Check ``flats`` (largest first) of group ``side`` against ``front``; returns ``(hits, flats checked)``."""
    own, other = groups[side], groups[1 - side].rows
    hits = checked = 0
    T, counts = threshold(front, side, most), _blind_counts(front, side)
    for mask, K in flats:
        a = int(mask.sum())
        if T is None or a < T:
            break  # largest first: every later flat is smaller
        key = mask.tobytes()
        m = _beyond_floor(counts, a) + 1
        if key in passed or m > most[1 - side]:
            continue
        budget.tick("sigma: front proof")
        checked += 1
        if K is None:
            K = _kernel(own.rows[mask].reshape(-1, own.n_columns), margins)
        best = _most_zeros(other @ K, m, budget, margins)
        if best is None:
            passed.add(key)
            continue
        hits += 1
        front.offer(maximal_zero_set(space, K @ best, margins)[None, :])
        T, counts = threshold(front, side, most), _blind_counts(front, side)
    return hits, checked


def _most_zeros(P: np.ndarray, m: int, budget: Budget, margins: Margins) -> np.ndarray | None:
    """A unit vector zeroing the most slots of ``P`` if that is at least ``m``, else ``None``."""
    best = None
    while m <= P.shape[0]:
        x = most_zeros_vector(P, m, budget, margins)
        if x is None:
            return best
        best = x
        m = int(margins.record(np.linalg.norm(P @ x, axis=1)).sum()) + 1
    return best
