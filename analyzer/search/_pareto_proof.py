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
*minimal beyond point* ``(a, B(a) + 1)``; those with ``a >= B(a) + 1`` are
checked from group 0 (flats of at least the least such ``a`` slots), the
others, whose group-1 counts are high, from group 1 (:func:`threshold`).
Flats of many slots in a block of few columns are rare, so the check
visits a small part of what the walk over both groups visits
(docs/structure.md gives the numbers).

Flats are those of one group, one per shift orbit (gap-canonical
rotation): a shift moves the phases of both groups together, so it maps
pairs to pairs.  For one flat, "some ``x`` in ``K(F)`` zeroes ``m`` rows of
``P = R K(F)``" (``R`` the other group's rows) is a largest-hyperplane
question in ``dim K(F)`` dimensions, answered exactly by the hyperplanes
spanned by ``dim K(F) - 1`` of the rows when there are few of them, and by
a closure search over the rows of ``P`` otherwise.  A hit is a real blind
set beyond the front: it joins the front and the check starts over, until
a whole pass leaves the front unchanged.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from .._budget import Budget
from ._affine import Affine, unit_symmetries
from ._blind import Flat, Margins, SlotSpace, expand, group_space, root
from ._blind_batch import walk


class Front(Protocol):
    """What the proof needs of :class:`kfio.search._pareto.Front` (which imports this module)."""

    space: SlotSpace
    lower: np.ndarray
    vectors: np.ndarray

    def offer(self, masks: np.ndarray) -> None:
        """Add maximal blind sets whose miss vectors the front does not dominate or equal."""
        ...  # pragma: no cover - protocol

    def copy(self) -> Front:
        """A front with the same vectors and sets, which later offers to either do not share."""
        ...  # pragma: no cover - protocol


#: Most ``(k - 1)``-subsets of the other group's rows (``C(n, k - 1)``) for which
#: :func:`_hyperplanes` answers; beyond it the closure search over the projected rows does.
_MOST_SUBSETS = 200_000


FlatList = list[tuple[np.ndarray, "np.ndarray | None"]]


class _BigFlats:
    """Collector of every flat of one group with at least ``T`` slots, with its kernel (``None``: to be computed).

    With ``on_found``, new flats are handed over in batches as the walk finds
    them (every :data:`_ONLINE_NODES` flats asked about, so a short walk
    hands them over once, at its end); it returns a new least size of
    interest (``None``: none), and ``T`` rises to it (never falls) for the
    rest of the walk.
    """

    def __init__(
        self,
        space: SlotSpace,
        T: int,
        on_found: Callable[[FlatList], int | None] | None = None,
        affine: Affine | None = None,
        on_seed: Callable[[FlatList], int | None] | None = None,
    ) -> None:
        self.space = space
        self.on_seed = on_seed
        self.T = T
        self.found: FlatList = []
        self.pending: FlatList = []
        self.seen: set[bytes] = set()
        self.on_found = on_found
        self.nodes = 0
        self.affine = affine
        self.orbits: set[bytes] = set()  # with affine: shift-orbit keys listed
        self.unrolled: FlatList = []  # with affine: flats found, not yet turned into shift orbits

    def _add(self, mask: np.ndarray, K: np.ndarray | None) -> None:
        key = mask.tobytes()
        if key in self.seen:
            return  # a maximal flat is visited with its kernel and then offered as a leaf
        self.seen.add(key)
        if self.affine is not None:
            self.unrolled.append((mask.copy(), K))
            return
        self.found.append((mask.copy(), K))
        if self.on_found is not None:
            self.pending.append(self.found[-1])

    def unroll(self) -> None:
        """With ``affine``: list every shift orbit in the affine orbits of the flats found since the last call.

        The unit multiples ``a^{-1} F`` of each flat, one per shift orbit
        (:meth:`kfio.search._affine.Affine.rotation_orbits`); ``F`` itself
        keeps its kernel, the others get theirs when they are checked.
        """
        if self.affine is None or not self.unrolled:
            return
        batch, self.unrolled = self.unrolled, []
        for mask, i, u in self.affine.rotation_orbits([m for m, _ in batch], self.orbits):
            self.found.append((mask, batch[i][1] if u == 0 else None))
            if self.on_found is not None:
                self.pending.append(self.found[-1])

    def flush(self) -> None:
        """Hand the pending flats to ``on_found`` and raise ``T`` to its answer.

        With ``affine``, ``on_seed`` first sees the flats found (one per
        affine orbit; sizes and ranks are those of every flat of the orbit)
        and may raise ``T``, so only the orbits of the flats of at least
        ``T`` slots are unrolled.
        """
        if self.affine is not None and self.unrolled:
            if self.on_seed is not None:
                T = self.on_seed(self.unrolled)
                self.T = max(self.T, self.space.size + 1 if T is None else T)
            self.unrolled = [flat for flat in self.unrolled if flat[0].sum() >= self.T]
        self.unroll()
        if self.on_found is None or not self.pending:
            return
        batch, self.pending = self.pending, []
        T = self.on_found(batch)
        self.T = max(self.T, self.space.size + 1 if T is None else T)

    def alive(self, masks: np.ndarray, cores: np.ndarray, kernels: np.ndarray) -> np.ndarray:
        """Flats below a flat with core ``c`` add only slots after ``c``; below a plane, only one parallel class.

        With a 2-dimensional kernel ``K`` every flat below is ``Q`` plus the
        later rows that vanish at one ``u`` in ``K``, i.e. whose projections
        ``r K`` are parallel: at most the largest class of (nearly) parallel
        projections, counted with margin, that holds no slot up to the core
        which ``Q`` misses (:func:`_most_parallel`).
        """
        self.nodes += masks.shape[0]
        if self.nodes >= _ONLINE_NODES:
            self.nodes = 0
            self.flush()
        later = (np.arange(self.space.size)[None, :] > cores[:, None]) & ~masks
        held = masks.sum(axis=1)
        ok: np.ndarray = held + later.sum(axis=1) >= self.T
        if kernels.shape[2] == 2 and self.space.rows.shape[1] == 1 and not np.iscomplexobj(self.space.rows):
            C, L, _ = kernels.shape
            # One product for the batch: (S x L) times (L x 2C), back to (C, S, 2).
            W = (
                (self.space.rows[:, 0, :] @ kernels.transpose(1, 0, 2).reshape(L, -1))
                .reshape(-1, C, 2)
                .transpose(1, 0, 2)
            )
            # Below Q no flat holds a slot up to the core that Q misses: a class of
            # such a slot is the closure of no child that keeps Q's prefix.
            before = ~later & ~masks
            ok &= held + _most_parallel(W, later, self.space.tol, poison=before) >= self.T
        return ok

    def alive_hulls(self, hulls: np.ndarray) -> np.ndarray:
        result: np.ndarray = hulls.sum(axis=1) >= self.T
        return result

    def visit(self, masks: np.ndarray, kernels: np.ndarray) -> None:
        if kernels.shape[2] == 0:
            return  # full rank: not blind
        for i in np.flatnonzero(masks.sum(axis=1) >= self.T):
            self._add(masks[i], kernels[i])

    def offer(self, masks: np.ndarray) -> None:
        for m in masks[masks.sum(axis=1) >= self.T]:
            self._add(m, None)


#: Projections shorter than this many tolerances count as parallel to every other.
_SHORT = 1e4


def _most_parallel(W: np.ndarray, rows: np.ndarray, tol: float, poison: np.ndarray | None = None) -> np.ndarray:
    """Per batch row, an upper bound on the most ``rows`` whose real 2-vectors ``W`` are parallel.

    Two rows count as parallel for the closure when one leaves a residual
    ``|W_t| |sin(angle)| <= tol`` against the other; a row with
    ``|W_t| >= _SHORT tol`` is then within ``1 / _SHORT`` radians of the
    class direction, so every class lies in one *chain* of angles (taken
    modulo pi, on a circle) with consecutive gaps of at most ``2 / _SHORT``;
    shorter rows are counted in every class.  A class counts no more than
    the ``rows`` of its chain.  With ``poison`` (rows that no class may
    hold), a chain is dropped when it holds a poison row and is *tight*:
    its angles spread less than ``tol / (2 max |W_t|)``, so each of its rows
    is parallel to each other.
    """
    C, n, _ = W.shape
    size = np.hypot(W[..., 0], W[..., 1])
    short = rows & (size < _SHORT * tol)
    counted = rows & ~short
    bad = np.zeros_like(rows) if poison is None else poison & (size >= _SHORT * tol)
    member = counted | bad
    angle = np.where(member, np.arctan2(W[..., 1], W[..., 0]) % np.pi, 8.0)  # 8 > pi: not in any chain
    k = np.count_nonzero(member, axis=1)
    inside = np.arange(n)[None, :] < k[:, None]
    if poison is None:
        angle = np.sort(angle, axis=1)
        counted = inside  # every member is counted
    else:
        order = np.argsort(angle, axis=1)
        angle = np.take_along_axis(angle, order, axis=1)
        counted = np.take_along_axis(counted, order, axis=1)
        bad = np.take_along_axis(bad, order, axis=1)
        size = np.take_along_axis(size, order, axis=1)
    # A chain starts where the gap from the angle before is large (or at the first angle).
    starts = np.ones((C, n), dtype=bool)
    starts[:, 1:] = angle[:, 1:] - angle[:, :-1] > 2.0 / _SHORT
    chain = np.cumsum(starts, axis=1) - 1
    # Across the wrap (the first angle plus pi after the last) the last chain is the first.
    has = k > 0
    lastpos = np.maximum(k - 1, 0)
    wraps = has & (angle[:, 0] + np.pi - angle[np.arange(C), lastpos] <= 2.0 / _SHORT)
    last_chain = chain[np.arange(C), lastpos]
    chain = np.where(wraps[:, None] & (chain == last_chain[:, None]) & inside, 0, chain)
    unwrapped = np.where(wraps[:, None] & (chain == 0) & (angle > np.pi / 2), angle - np.pi, angle)
    ids = (np.arange(C)[:, None] * n + chain)[inside]
    counts = np.bincount(ids, weights=counted[inside], minlength=C * n)
    if poison is not None:
        poisoned = np.bincount(ids, weights=bad[inside], minlength=C * n) > 0
        hi = np.full(C * n, -4.0)  # angles lie in (-pi/2, pi): an empty chain spans -8, times size 0
        lo = np.full(C * n, 4.0)
        big = np.zeros(C * n)
        np.maximum.at(hi, ids, unwrapped[inside])
        np.minimum.at(lo, ids, unwrapped[inside])
        np.maximum.at(big, ids, size[inside])
        tight = (hi - lo) * big < tol / 2
        counts[poisoned & tight] = 0
    best = counts.reshape(C, n).max(axis=1)
    return np.asarray(best.astype(int) + np.count_nonzero(short, axis=1))


def parallel_chains(W: np.ndarray, rows: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """The chains of :func:`_most_parallel` per batch row: a label per row of ``rows`` (``-1``: none) and the short rows.

    Rows of ``rows`` with ``|W_t| >= _SHORT tol`` get the label of their
    chain of angles (modulo pi, consecutive gaps at most ``2 / _SHORT``,
    the last chain joined to the first across the wrap), ``0, 1, ...`` per
    batch row; every set of rows parallel for the closure lies in one
    chain plus the short rows (the argument of :func:`_most_parallel`).
    """
    C, n, _ = W.shape
    size = np.hypot(W[..., 0], W[..., 1])
    short = rows & (size < _SHORT * tol)
    member = rows & ~short
    angle = np.where(member, np.arctan2(W[..., 1], W[..., 0]) % np.pi, 8.0)
    k = np.count_nonzero(member, axis=1)
    order = np.argsort(angle, axis=1)
    angle = np.take_along_axis(angle, order, axis=1)
    inside = np.arange(n)[None, :] < k[:, None]
    starts = np.ones((C, n), dtype=bool)
    starts[:, 1:] = angle[:, 1:] - angle[:, :-1] > 2.0 / _SHORT
    chain = np.cumsum(starts, axis=1) - 1
    lastpos = np.maximum(k - 1, 0)
    wraps = (k > 0) & (angle[:, 0] + np.pi - angle[np.arange(C), lastpos] <= 2.0 / _SHORT)
    last_chain = chain[np.arange(C), lastpos]
    chain = np.where(wraps[:, None] & (chain == last_chain[:, None]) & inside, 0, chain)
    chain = np.where(inside, chain, -1)
    labels = np.full((C, n), -1)
    np.put_along_axis(labels, order, chain, axis=1)
    return labels, short


#: Most ``(flat, pivot)`` pairs of :func:`pivot_projections` in one piece.
_PIVOT_PAIRS = 1 << 12


def pivot_projections(
    W: np.ndarray, rows: np.ndarray, need: np.ndarray | None = None
) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """Per ``(batch row c, pivot p)``: ``c``, ``p``, the rows ``V`` of ``W[c]`` orthogonal to ``W[c, p]`` in plane coordinates, and the members.

    The members are the ``rows`` no longer than the pivot (ties by
    position), the pivot included.  Rows ``s`` of a set ``P`` with
    ``|W_s . x| <= tol`` for a unit ``x`` (the slots a kernel vector ``x``
    zeroes), and ``p`` the longest of them: with ``u = W_p / |W_p|`` and
    ``V_s = W_s - (W_s . u) u``, ``|x . u| <= tol / |W_p|`` and
    ``V_s . x = W_s . x - (W_s . u)(u . x)``, so ``|V_s . x| <= 2 tol``: in
    the plane orthogonal to ``u`` every ``V_s`` lies within
    ``2 tol / |x - (x . u) u|`` of one line, one class of
    :func:`parallel_chains` with ``3 tol``.  With
    ``need``, only the pivots among the ``k - need + 1`` longest of the
    ``k`` rows (the longest row of a set of ``need`` rows is one of them).
    Yields pieces of at most :data:`_PIVOT_PAIRS` pairs.
    """
    C, n, _ = W.shape
    size = np.where(rows, np.linalg.norm(W, axis=2), -1.0)
    # Rank of each row by length, longest first (ties by position).
    order = np.argsort(-size, axis=1, kind="stable")
    place = np.empty_like(order)
    np.put_along_axis(place, order, np.arange(n)[None, :].repeat(C, axis=0), axis=1)
    pivot = rows & (size > 0)
    if need is not None:
        k = rows.sum(axis=1)
        pivot &= place < (k - np.maximum(need, 1) + 1)[:, None]
    cs, ps = np.nonzero(pivot)
    for part in _pieces(cs.size, _PIVOT_PAIRS):
        c, p = cs[part], ps[part]
        u = W[c, p] / size[c, p][:, None]
        # Two unit vectors orthogonal to u (and to each other): the plane's coordinates.
        a = np.where(np.abs(u[:, :1]) < 0.9, np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
        e1 = a - (a * u).sum(axis=1)[:, None] * u
        e1 /= np.linalg.norm(e1, axis=1)[:, None]
        e2 = np.cross(u, e1)
        V = W[c] @ np.stack([e1, e2], axis=2)
        yield c, p, V, rows[c] & (place[c] >= place[c, p][:, None])


def _pieces(n: int, step: int) -> list[slice]:
    return [slice(i, i + step) for i in range(0, n, step)]


#: Flats the walk of :func:`big_flats` asks about between two hand-overs to ``on_found``.
_ONLINE_NODES = 4096


def big_flats(
    space: SlotSpace,
    T: int,
    budget: Budget,
    margins: Margins,
    on_found: Callable[[FlatList], int | None] | None = None,
    affine: Affine | None = None,
    on_seed: Callable[[FlatList], int | None] | None = None,
) -> tuple[FlatList, int]:
    """Every blind flat of a one-group space with at least ``T`` slots, one per shift orbit, and the least size kept.

    The batched closure walk of :func:`kfio.search._blind_batch.walk`
    (gap-canonical rotation), cutting every subtree whose hull holds fewer
    than ``T`` slots.  Expanded flats come with an orthonormal kernel basis;
    maximal ones (``None``) get theirs when they are checked, most never are.
    With ``on_found`` (see :class:`_BigFlats`) the size ``T`` may rise during
    the walk: every flat of at least the returned size is listed.

    With ``affine`` (maps that preserve the matroid of ``space``,
    :func:`kfio.search._affine.unit_symmetries`) the walk lists one flat per
    affine orbit, each then unrolled into one per shift orbit (after
    ``on_seed``, see :meth:`_BigFlats.flush`).
    """
    found = _BigFlats(space, T, on_found, affine, on_seed)
    walk(space, budget, margins, found, affine=affine)
    found.flush()
    return found.found, found.T


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
    return most_zeros_vectors(P[None], np.array([m]), budget, margins)[0]


def most_zeros_vectors(P: np.ndarray, m: np.ndarray, budget: Budget, margins: Margins) -> list[np.ndarray | None]:
    """:func:`most_zeros_vector` for each ``P[b]`` (``B x N x p x k``) and ``m[b]``, the hyperplanes of all at once.

    One batched :func:`_hyperplanes` walk serves every item that needs it,
    so many small questions cost a few large array operations.
    """
    B, N, p, k = P.shape
    out: list[np.ndarray | None] = [None] * B
    e0 = np.zeros(k, dtype=P.dtype)
    e0[0] = 1
    walk: list[int] = []
    for b in range(B):
        zero = margins.record(np.linalg.norm(P[b].reshape(N, -1), axis=1))
        need = int(m[b]) - int(zero.sum())
        if need <= 0:
            out[b] = e0
            continue
        rows = P[b, ~zero]
        if k == 1 or rows.shape[0] < need:
            continue
        if p > 1 or math.comb(rows.shape[0], k - 1) > _MOST_SUBSETS:
            out[b] = _closure_hit(P[b], int(m[b]), budget, margins)
            continue
        if need <= k - 1:
            out[b] = _kernel(rows[: k - 1, 0, :], margins)[:, 0]
            continue
        whole = _kernel(rows[:, 0, :], margins)
        if whole.shape[1] > 0:
            out[b] = whole[:, 0]
            continue
        walk.append(b)
    if walk:
        # Zero rows stay: they lie on every hyperplane, so ``m`` (not ``need``) is what counts.
        for b, x in zip(walk, _hyperplanes(P[walk, :, 0, :], m[walk], budget, margins)):
            out[b] = x
    return out


#: Flats asked together in :func:`_check` (one batched hyperplane walk).
_FLATS_PER_BATCH = 64

#: Most hyperplanes (``C(rows, k - 1)`` a flat) one batched walk may reach: bounds its memory.
_BATCH_PREFIXES = 1 << 19

#: Most prefix rows of one level of :func:`_hyperplanes` handled in one array operation.
_CHUNK = 1 << 14


def _hyperplanes(R: np.ndarray, need: np.ndarray, budget: Budget, margins: Margins) -> list[np.ndarray | None]:
    """Per ``b``, a normal ``x`` of a hyperplane holding ``need[b]`` of the rows of ``R[b]`` (``B x n x k``), or ``None``.

    The rows of each ``R[b]`` span ``C^k``.  Every hyperplane ``H`` spanned
    by ``k - 1`` independent rows is reached once, by its *greedy basis*:
    ``s_1`` its first row, each next ``s`` its first row outside the span so
    far.  Then every row of ``H`` up to the last ``s`` lies in that span, so
    a prefix needs only the rows after its last ``s`` (its *window*), and
    the number of spanned rows (``held``); a child adding row ``e`` that
    brings an earlier row into the span is no greedy basis and is not
    followed.  Per prefix the walk keeps ``W = R N`` on the window, the rows
    in an orthonormal basis ``N`` of the vectors the prefix annihilates
    (``|W_t|`` is the distance of row ``t`` from the prefix's span); adding
    row ``e`` multiplies ``W`` by the columns of the Householder reflection
    that maps ``W_e`` onto the first axis (all but the first), ``O(n d)``
    per prefix; at the end ``W`` is one column, the rows' distances from
    the hyperplane.  Prefixes with one last row share a window and walk
    together, those of every ``b`` alike (``owner`` says whose each is).
    """
    B, n, k = R.shape
    real = not np.iscomplexobj(R)
    # first row of the window -> the prefixes whose window starts there
    windows: dict[int, list[_Prefixes]] = {
        0: [_Prefixes(np.arange(B), np.zeros(B, dtype=int), np.zeros((B, 0), dtype=int), R)]
    }
    out: list[np.ndarray | None] = [None] * B
    for level in range(k):
        nxt: dict[int, list[_Prefixes]] = {}
        for lo in sorted(windows):
            every = _Prefixes.concat(windows[lo])
            for s in range(0, every.owner.size, _CHUNK):
                p = every.chunk(s, s + _CHUNK)
                owner, W = p.owner, p.W
                budget.tick("sigma: front proof", max(1, owner.size * W.shape[1] // 4096))
                size = np.sqrt(_squares(W))
                spanned = margins.record(size)
                held = p.held_before + np.count_nonzero(spanned, axis=1)
                if level == k - 1:  # W is one column: the rows on each hyperplane
                    for c in np.flatnonzero(held >= need[owner]):
                        if out[owner[c]] is None:  # the normal of the k - 1 picked rows
                            out[owner[c]] = np.linalg.svd(R[owner[c], p.picked[c]])[2][-1].conj()
                    continue
                after = ~spanned
                cum = np.cumsum(after, axis=1)
                alive = held + cum[:, -1] >= need[owner]
                if W.shape[2] == 2 and real:
                    # The hyperplanes through a prefix with a plane of normals hold its
                    # span plus one class of parallel projections: count the largest.
                    alive[alive] &= (
                        held[alive] + _most_parallel(W[alive], after[alive], margins.tol) >= need[owner[alive]]
                    )
                # A child adding e holds the spanned rows, e, and at most the others after e.
                room = (held + 1 + cum[:, -1] - need[owner])[:, None] >= cum
                parent, e = np.nonzero(alive[:, None] & after & room)
                if parent.size == 0:
                    continue
                order = np.argsort(e, kind="stable")
                parent, e = parent[order], e[order]
                children = _Prefixes(
                    owner[parent],
                    p.held_before[parent] + np.cumsum(spanned, axis=1)[parent, e] + 1,
                    np.column_stack([p.picked[parent], lo + e]),
                    _reflect_out(W[parent], W[parent, e] / size[parent, e][:, None]),
                )
                cuts = np.flatnonzero(np.diff(e)) + 1
                for first, stop in zip(np.concatenate([[0], cuts]), np.concatenate([cuts, [e.size]])):
                    row = int(e[first])  # the row the children of this run added, in window coordinates
                    # A child whose window is empty (e the last row) adds no row after e: its
                    # hyperplane holds no more rows than span(prefix) + r_t, r_t an earlier row outside it.
                    if row + 1 < W.shape[1]:
                        nxt.setdefault(lo + row + 1, []).append(children.chunk(first, stop, window_from=row + 1))
        windows = nxt
    return out


@dataclass(frozen=True)
class _Prefixes:
    """Prefixes of greedy bases in :func:`_hyperplanes` that share one window, as parallel arrays.

    ``owner[i]`` is the ``b`` of ``R[b]`` prefix ``i`` belongs to;
    ``held_before[i]`` counts its rows spanned before the window;
    ``picked[i]`` lists the rows it picked (its greedy basis so far);
    ``W[i]`` holds the window's rows in an orthonormal basis of the vectors
    the prefix annihilates (``|W[i, t]|`` is row ``t``'s distance from the
    prefix's span).
    """

    owner: np.ndarray
    held_before: np.ndarray
    picked: np.ndarray
    W: np.ndarray

    @staticmethod
    def concat(parts: Sequence[_Prefixes]) -> _Prefixes:
        """One set of prefixes from several that share a window."""
        return _Prefixes(*(np.concatenate(q) for q in zip(*((x.owner, x.held_before, x.picked, x.W) for x in parts))))

    def chunk(self, start: int, stop: int, window_from: int = 0) -> _Prefixes:
        """Prefixes ``start:stop``, their window cut to begin at row ``window_from``."""
        return _Prefixes(
            self.owner[start:stop],
            self.held_before[start:stop],
            self.picked[start:stop],
            self.W[start:stop, window_from:],
        )


def _squares(W: np.ndarray) -> np.ndarray:
    """``|W_t|^2`` over the last (short) axis, one column at a time (faster than a reduction over it)."""
    if np.iscomplexobj(W):
        return np.asarray((W * W.conj()).real.sum(axis=-1))
    out = W[..., 0] * W[..., 0]
    for j in range(1, W.shape[-1]):
        out += W[..., j] * W[..., j]
    return np.asarray(out)


def _reflect_out(N: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Per item, ``N H`` with ``H`` orthonormal columns spanning ``{y : w . y = 0}`` (``N``: ``(C, m, d)``, ``w``: unit ``(C, d)``).

    ``H`` holds the last ``d - 1`` columns of the Householder reflection
    ``I - 2 v v^* / |v|^2``, ``v = conj(w) + s e_1`` (``s`` of the modulus
    one and phase of ``conj(w_1)``, so nothing cancels), which maps
    ``conj(w)`` to a multiple of ``e_1``; a rank-one update gives ``N H``.
    """
    u = w.conj()
    first = u[:, 0]
    phase = np.where(np.abs(first) > 0, first / np.maximum(np.abs(first), 1e-300), 1.0)
    v = u.copy()
    v[:, 0] += phase
    scale = 2.0 / np.einsum("cd,cd->c", v.conj(), v).real
    Nv = N[:, :, 0] * v[:, None, 0]
    for j in range(1, N.shape[2]):  # a few columns: cheaper than a reduction over a short axis
        Nv += N[:, :, j] * v[:, None, j]
    return np.asarray(N[:, :, 1:] - (scale[:, None] * Nv)[:, :, None] * v[:, None, 1:].conj())


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
    counts.  A set beyond the front lies above the point ``(x, B(x) + 1)``
    of its own count ``x`` in group 0 (``B`` from group 0's side).  Group 0
    checks every flat of at least ``T_0`` slots, the least ``a`` with
    ``a >= B(a) + 1`` (and ``B(a) + 1`` at most group 1's ``most``), and
    so every set with ``x >= T_0``.  A set with ``x < T_0`` has at least
    ``B(T_0 - 1) + 1`` slots of group 1 (``B`` does not rise with ``x``):
    group 1 checks every flat of that many slots.  Every set beyond the
    front is checked from one side.
    """
    counts = _blind_counts(front, 0)
    T0 = None
    for a in range(most[0] + 1):
        b = _beyond_floor(counts, a) + 1
        if a >= b and b <= most[1]:
            T0 = a
            break
    if side == 0:
        return T0
    top = most[0] if T0 is None else T0 - 1
    if top < 0:
        return None  # group 0 checks every flat: nothing is left to group 1
    T1 = _beyond_floor(counts, top) + 1
    return T1 if T1 <= most[1] else None


def prove_front(space: SlotSpace, front: Front, budget: Budget, margins: Margins) -> int:
    """Add to ``front`` until no maximal blind set of a two-group ``space`` beats it; returns the flats checked.

    Runs :class:`FrontProof` (its docstring states the invariant and why the
    loop ends).  Raises :class:`~kfio.errors.BudgetExceeded` when ``budget``
    runs out.
    """
    return FrontProof(space, front, budget, margins).run()


class FrontProof:
    """The proof that a two-group front is complete, as named state (see the module docstring).

    Flats are checked as the walk finds them (largest first within each
    hand-over, after seeding the generic front from the largest flat of
    each rank so far), then all of them largest first until a pass leaves
    the front as it was; a hit is pushed to the most slots of the other
    group that ``K(F)`` can zero, so the front, and with it the thresholds
    and the size the walk needs, rise early.  When the rows of group 1 are
    those of group 0 times one invertible matrix (:func:`shared_matroid`),
    both groups have the same flats and one walk serves both.

    State:

    * ``front``: the blind-count vectors found; it only grows (as a lower set).
    * ``walked[source]``: ``(T, flats)``, the flats of at least ``T`` slots
      the walk over group ``source`` listed, largest first.
    * ``passed[side]``: flats of group ``side`` shown to hold no kernel
      vector zeroing ``B(|F|) + 1`` rows of the other group.
    * ``largest[side]``, ``seeded``: the largest flat per rank and the rank
      pairs already offered as generic-front seeds (:func:`seed_generic`).
    * ``checked``: flats checked so far; ``passes``: the front's size after
      each pass of :meth:`run`.

    Invariant: every flat in ``passed[side]`` holds no vector beating the
    current front.  It is kept because the count ``B(|F|) + 1`` a flat must
    reach only rises as the front grows, so a flat that held none keeps
    holding none: each flat is checked once.

    Why :meth:`run` ends: a pass in which the front did not change proves
    it (every threshold held still, each side's list reached down to it,
    and each of its flats passed), and :meth:`run` returns.  Any other pass
    added a blind-count vector no earlier vector dominated, so the lower
    set of the front strictly grew; it lies in the finite grid
    ``[0, most[0]] x [0, most[1]]``, so at most ``(most[0] + 1) (most[1] + 1)``
    passes change it.  (A change can lower group 1's threshold below what it
    checked, since a higher ``T_0`` leaves it more, which is why one pass
    does not suffice.)
    """

    def __init__(
        self,
        space: SlotSpace,
        front: Front,
        budget: Budget,
        margins: Margins,
        affine: bool | None = None,
        give_up: bool = False,
    ) -> None:
        self.space, self.front, self.budget, self.margins = space, front, budget, margins
        n = space.n_phases
        self.most = (n - int(front.lower[0]), n - int(front.lower[1]))
        self.groups = [group_space(space, g) for g in (0, 1)]
        self.shared = shared_matroid(self.groups[0], self.groups[1], margins)
        self.affine = [_affine_of(g, affine) for g in self.groups]
        # The certificate (:meth:`_certify`): hand-overs of the walk so far, the one at which the
        # front last changed and the one of the last certificate tried, whether the walked groups
        # have affine maps (None: not asked yet); with give_up, the vectors the proof gives up on
        # changing (raising _Premature).
        self.handovers = 0
        self.changed_at = 0
        self.tried_at = 0
        self.certifiable: bool | None = None
        self.give_up = front.vectors if give_up else None
        self.walked: dict[int, tuple[int, FlatList]] = {}
        self.passed: dict[int, set[bytes]] = {0: set(), 1: set()}
        self.largest: list[dict[int, np.ndarray]] = [{}, {}]
        self.seeded: set[bytes] = set()
        self.classes: list[dict[tuple[int, int], np.ndarray]] = [{}, {}]
        self.tried: set[tuple[int, int, int, int]] = set()
        self.checked = 0
        self.passes: list[int] = []

    def run(self) -> int:
        """Pass over both sides until a pass leaves the front unchanged; returns the flats checked.

        Returns early, with the same front and the same representative
        sets, once a certificate shows the front final (:meth:`_certify`).
        With ``give_up``, raises :class:`_Premature` as soon as the front
        changes.
        """
        try:
            while True:
                start = self.front.vectors.copy()
                for side in (0, 1):
                    T = threshold(self.front, side, self.most)
                    if T is not None:
                        self.checked += self._check(side, self.flats(side, T))
                        self._give_up_if_changed()
                self.passes.append(len(self.front.vectors))
                if np.array_equal(start, self.front.vectors):
                    return self.checked
        except _Complete:
            return self.checked

    def _give_up_if_changed(self) -> None:
        """With ``give_up``: raise :class:`_Premature` once the front is no longer the one the proof started from."""
        if self.give_up is not None and self.front.vectors is not self.give_up:  # offer replaces changed vectors
            raise _Premature

    def _certify(self) -> None:
        """Raise :class:`_Complete` if a second proof, over a copy of the front and with the affine walk, changes nothing.

        The second proof lists one sensor's big flats once per affine orbit
        (:mod:`kfio.search._affine`: the same flats, met up to ``phi(N0)``
        times sooner) and checks them against its copy.  If it ends with
        the copy unchanged, no maximal blind set has a vector the front
        does not dominate or equal: the front is final, and so are its
        representative sets, since :meth:`kfio.search._pareto.Front.offer`
        changes neither for such a set.  Stopping now gives the answer this
        proof would reach at its end, set for set.  The second proof gives
        up at its first change of the copy (its hits cannot be offered
        here: the set representing a vector is the first one *this* proof
        offers), and a later hand-over tries again (:meth:`_on_found`).
        Nothing is tried when a walked group has only the rotations.
        """
        self.tried_at = self.handovers
        if self.certifiable is None:
            walked = [self.groups[0]] if self.shared is not None else self.groups
            self.certifiable = all(_affine_of(g, True) is not None for g in walked)
        if not self.certifiable:
            return
        proof = FrontProof(self.space, self.front.copy(), self.budget, self.margins, affine=True, give_up=True)
        try:
            proof.run()
        except _Premature:
            self.checked += proof.checked
            return
        self.checked += proof.checked
        raise _Complete

    def served(self, source: int) -> tuple[int, ...]:
        """The groups whose flats the walk over ``source`` lists."""
        return (0, 1) if self.shared is not None else (source,)

    def least(self, source: int) -> int | None:
        """The fewest slots of a flat that some group served by ``source`` must check."""
        Ts = [t for t in (threshold(self.front, g, self.most) for g in self.served(source)) if t is not None]
        return min(Ts) if Ts else None

    @staticmethod
    def as_side(side: int, source: int, found: FlatList) -> FlatList:
        """``found`` (flats of group ``source``) as flats of ``side``: same masks, kernels from ``side``'s rows."""
        if side == source:
            return found
        return [(mask, None) for mask, _ in found]

    def flats(self, side: int, T: int) -> FlatList:
        """The flats of group ``side`` with at least ``T`` slots, largest first (walked once per lower ``T``)."""
        source = 0 if self.shared is not None else side
        if source not in self.walked or self.walked[source][0] > T:
            want = self.least(source)  # at most T: side is one of the groups served

            def on_found(batch: FlatList) -> int | None:
                return self._on_found(source, batch)

            def on_seed(batch: FlatList) -> int | None:
                self._seed(source, sorted(batch, key=_largest_first))
                return self.least(source)

            found, kept = big_flats(
                self.groups[source],
                T if want is None else min(T, want),
                self.budget,
                self.margins,
                on_found,
                self.affine[source],
                on_seed,
            )
            found.sort(key=_largest_first)
            self.walked[source] = (kept, found)
        return self.as_side(side, source, self.walked[source][1])

    def _on_found(self, source: int, batch: FlatList) -> int | None:
        """Check a batch as the walk finds it: a hit raises the front, and with it the size the walk needs."""
        batch = sorted(batch, key=_largest_first)
        before = self.front.vectors
        self._seed(source, batch)
        for g in self.served(source):
            if threshold(self.front, g, self.most) is not None:
                self.checked += self._check(g, self.as_side(g, source, batch))
        self._give_up_if_changed()
        self.handovers += 1
        if self.front.vectors is not before:  # Front.offer replaces the array when the front changes
            self.changed_at = self.handovers
        # A certificate once the walk has made twice the hand-overs it had made at the last change
        # of the front and at the last certificate tried (a doubling rule: the waits cost at most
        # what came before them, and a certificate tried at low thresholds walks many flats).
        if (
            CERTIFY
            and self.affine[source] is None
            and self.certifiable is not False
            and self.handovers >= max(_CERTIFY_AFTER, _CERTIFY_FACTOR * max(self.changed_at, self.tried_at))
        ):
            self._certify()
        return self.least(source)

    def _seed(self, source: int, batch: FlatList) -> None:
        """Keep the largest flat per rank of ``batch`` (largest first) and offer the generic front they give."""
        for g in self.served(source):
            largest_by_rank(batch, self.space.n_columns, self.largest[g])
        seed_generic(self.space, self.front, self.groups, self.largest, self.margins, self.seeded)
        if self.affine[source] is not None:
            for g in self.served(source):
                first_by_class(batch, self.space.n_columns, self.classes[g])
            seed_meets(self.space, self.front, self.groups, self.classes, self.margins, self.tried)

    def _check(self, side: int, flats: FlatList) -> int:
        return _check(
            self.space,
            self.front,
            side,
            flats,
            self.groups,
            self.passed[side],
            self.most,
            self.budget,
            self.margins,
        )


#: Whether the front proof lists one group's big flats once per affine orbit when its matroid allows it.
#: Off: the fronts are the same, but a hit of the proof may come from another flat first, so the set
#: representing a front vector (shown in the answer) can differ from the rotation walk's.
AFFINE = False


#: Whether the front proof, after a long walk with no change of the front, tries to show the front final
#: by a proof with the affine walk over a copy of it, and stops if so (:meth:`FrontProof._certify`): the
#: same answer, representative sets included.
CERTIFY = True

#: Fewest hand-overs of the walk (:data:`_ONLINE_NODES` flats asked each) before a certificate is tried.
_CERTIFY_AFTER = 16

#: A certificate is tried once the walk has made this many times the hand-overs it had made at the last
#: change of the front and at the last certificate tried.
_CERTIFY_FACTOR = 2


class _Complete(Exception):
    """A certificate showed the front final: no later offer can change it."""


class _Premature(Exception):
    """A certificate's proof changed its copy of the front: the front was not final."""


def _affine_of(space: SlotSpace, affine: bool | None = None) -> Affine | None:
    """The affine maps preserving the matroid of one group (:mod:`kfio.search._affine`), ``None``: rotations only.

    ``affine``: ``None`` follows :data:`AFFINE`; ``True`` or ``False`` decides.
    """
    if not (AFFINE if affine is None else affine):
        return None
    maps = Affine(space.n_phases, unit_symmetries(space))
    return None if maps.trivial else maps


def _largest_first(flat: tuple[np.ndarray, np.ndarray | None]) -> tuple[int, int]:
    """Sort key: most slots first, then (for batches of one kernel dimension) by kernel dimension."""
    mask, K = flat
    return -int(mask.sum()), 1 if K is None else K.shape[1]


def largest_by_rank(flats: FlatList, L: int, largest: dict[int, np.ndarray]) -> None:
    """Keep in ``largest`` the flat of most slots of each rank (maximal flats, with no kernel given, have rank ``L - 1``)."""
    for mask, K in flats:
        r = L - 1 if K is None else L - K.shape[1]
        if r not in largest or mask.sum() > largest[r].sum():
            largest[r] = mask


def seed_generic(
    space: SlotSpace,
    front: Front,
    groups: list[SlotSpace],
    largest: list[dict[int, np.ndarray]],
    margins: Margins,
    seeded: set[bytes] | None = None,
) -> None:
    """Offer the *generic front*: for ``r_0 + r_1 = L - 1``, the largest known flats of those ranks share a kernel vector.

    Flats ``F_0`` of group 0 and ``F_1`` of group 1 with ranks ``r_0 + r_1 =
    L - 1`` have kernels of dimensions ``L - r_0`` and ``L - r_1``, which sum
    to ``L + 1``: they meet, and a common kernel vector zeroes both, so the
    blind counts ``(|F_0|, |F_1|)`` are attained whatever the rows.  From
    the largest flat of each rank of each group (:func:`largest_by_rank`),
    so the proof starts from thresholds near their final values; pairs in
    ``seeded`` are skipped, and the new ones added to it.
    """
    L = space.n_columns
    for r, F0 in largest[0].items():
        F1 = largest[1].get(L - 1 - r)
        if F1 is None:
            continue
        key = F0.tobytes() + F1.tobytes()
        if seeded is not None:
            if key in seeded:
                continue
            seeded.add(key)
        K0 = _kernel(groups[0].rows[F0].reshape(-1, L), margins)
        K1 = _kernel(groups[1].rows[F1].reshape(-1, L), margins)
        both = _kernel(np.concatenate([K0, -K1], axis=1), margins)
        if both.shape[1] == 0:
            continue  # the rank calls of the walk and of this factorization disagree: offer nothing
        u = K0 @ both[: K0.shape[1], 0]
        front.offer(maximal_zero_set(space, u / np.linalg.norm(u), margins)[None, :])


def first_by_class(flats: FlatList, L: int, classes: dict[tuple[int, int], np.ndarray]) -> None:
    """Keep in ``classes`` the first flat of each ``(rank, slots)`` (maximal flats, with no kernel given, have rank ``L - 1``)."""
    for mask, K in flats:
        key = (L - 1 if K is None else L - K.shape[1], int(mask.sum()))
        if key not in classes:
            classes[key] = mask


#: Most pairs of flat classes :func:`seed_meets` intersects in one call.
_MEETS = 4096


def seed_meets(
    space: SlotSpace,
    front: Front,
    groups: list[SlotSpace],
    classes: list[dict[tuple[int, int], np.ndarray]],
    margins: Margins,
    tried: set[tuple[int, int, int, int]],
) -> None:
    """Offer the blind sets of flats ``F_0``, ``F_1`` (one per class of each group) whose kernels meet beyond ``front``.

    Where ranks sum to less than ``L - 1`` the kernels meet only for
    special rows, e.g. when both flats come from one block of a
    block-diagonal plant (for ``Phi_3``, ``Phi_4``, ``Phi_7`` the words of
    the ``Phi_7`` part alone give the front ``(12 i, 12 (5 - i))``).  A
    common kernel vector ``u`` zeroes both flats, a real blind set that
    raises the front early; the proof does not rely on it.  Pairs whose
    counts the front already dominates are skipped, the largest first, at
    most :data:`_MEETS` per call; pairs tried once are not tried again.
    """
    L = space.n_columns
    counts = _blind_counts(front, 0)
    pairs = sorted(
        ((r0, s0, r1, s1) for (r0, s0) in classes[0] for (r1, s1) in classes[1] if (r0, s0, r1, s1) not in tried),
        key=lambda p: -(p[1] + p[3]),
    )
    done = 0
    for r0, s0, r1, s1 in pairs:
        if done >= _MEETS:
            break
        if any(x >= s0 and y >= s1 for x, y in counts):
            continue
        tried.add((r0, s0, r1, s1))
        done += 1
        K0 = _kernel(groups[0].rows[classes[0][(r0, s0)]].reshape(-1, L), margins)
        K1 = _kernel(groups[1].rows[classes[1][(r1, s1)]].reshape(-1, L), margins)
        if K0.shape[1] + K1.shape[1] > L:
            continue  # a generic meet: seed_generic offers those
        both = _kernel(np.concatenate([K0, -K1], axis=1), margins)
        if both.shape[1] == 0:
            continue
        u = K0 @ both[: K0.shape[1], 0]
        front.offer(maximal_zero_set(space, u / np.linalg.norm(u), margins)[None, :])
        counts = _blind_counts(front, 0)


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
    flats: FlatList,
    groups: list[SlotSpace],
    passed: set[bytes],
    most: tuple[int, int],
    budget: Budget,
    margins: Margins,
) -> int:
    """Check ``flats`` (largest first) of group ``side`` against ``front``; returns the flats checked.

    Flats are asked in batches of one kernel dimension (:func:`most_zeros_vectors`)
    with the counts ``m`` of the front as it stands.  Up to the first hit of a
    batch the answers are those of one flat at a time; after it the front
    has grown, so ``m`` has not fallen and every flat that held no ``m`` then
    holds none now (it is passed), while the others are asked again.
    """
    own, other = groups[side], groups[1 - side].rows
    checked = 0
    T, counts = threshold(front, side, most), _blind_counts(front, side)
    i = 0
    while i < len(flats):
        batch: list[tuple[int, bytes, np.ndarray]] = []
        ms: list[int] = []
        limit = _FLATS_PER_BATCH
        while i < len(flats) and len(batch) < limit:
            mask, K = flats[i]
            a = int(mask.sum())
            if T is None or a < T:
                i = len(flats)  # largest first: every later flat is smaller
                break
            key = mask.tobytes()
            m = _beyond_floor(counts, a) + 1
            if key in passed or m > most[1 - side]:
                i += 1
                continue
            if K is None:
                K = _kernel(own.rows[mask].reshape(-1, own.n_columns), margins)
            if batch and K.shape[1] != batch[0][2].shape[1]:
                break
            # Memory: the last level of a hyperplane walk holds up to C(rows, k - 1) prefixes a flat.
            reach = max(1, math.comb(other.shape[0], max(K.shape[1] - 1, 0)))
            limit = max(1, min(_FLATS_PER_BATCH, _BATCH_PREFIXES // reach))
            batch.append((i, key, K))
            ms.append(m)
            i += 1
        if not batch:
            continue
        budget.tick("sigma: front proof", len(batch))
        P = np.stack([other @ K for _, _, K in batch])
        answers = most_zeros_vectors(P, np.array(ms), budget, margins)
        first_hit = None
        for (j, key, K), x in zip(batch, answers):
            if x is None:
                passed.add(key)
                checked += 1
            elif first_hit is None:
                first_hit = j
                checked += 1
                best = _most_zeros(other @ K, x, budget, margins)
                front.offer(maximal_zero_set(space, K @ best, margins)[None, :])
                T, counts = threshold(front, side, most), _blind_counts(front, side)
        if first_hit is not None:
            i = first_hit + 1  # later flats with an answer are asked again with the grown front
    return checked


def _most_zeros(P: np.ndarray, x: np.ndarray, budget: Budget, margins: Margins) -> np.ndarray:
    """A unit vector zeroing the most slots of ``P``, pushed up from ``x``."""
    while True:
        m = int(margins.record(np.linalg.norm(P @ x, axis=1)).sum()) + 1
        better = most_zeros_vector(P, m, budget, margins) if m <= P.shape[0] else None
        if better is None:
            return x
        x = better
