"""Enumeration of every maximal blind orbit, many flats per batched step.

With several sensors every shift orbit of maximal blind sets is enumerated
(Rohr, Marelli and Fu (2014), Lemma 3: ``sigma = max_F rho(M_F)`` over all of them, and exact
stability regions need every binding pattern).  The search of
:func:`kfio.search._blind.search` walks flats one at a time; the order of
the walk does not matter when nothing is pruned by an incumbent (the window
bound ``j_max`` is the same for every node), so here all flats of one kernel
dimension waiting on the stack are expanded together: one batched product
``W = r K`` per batch, one batched set of closure residuals for every
``(flat, slot)`` pair, and the children's kernels from one batched SVD of
their cut rows.  The flats visited, the rank calls and the orbits found are
those of the one-at-a-time walk (prefix-preserving closure extension of Uno,
Asai, Uchida and Arimura 2004 with canonical rotations); only the Python
overhead per flat (about 1 ms, numpy calls on ``S x L`` arrays) is shared by
the batch.

Found sets are keyed by their packed bits before their orbit key is taken,
so a hyperplane reached from several rotations costs one key.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Protocol

import numpy as np

from .._budget import Budget
from ._affine import Affine
from ._blind import Margins, SearchResult, SlotSpace, _chunks, root

#: Most flats expanded in one batched step.
_BATCH = 256

#: Most complex entries of one batched array (about 64 MB).
_ENTRIES = 1 << 22


class Collector(Protocol):
    """What the batched walk reports maximal blind sets to, and asks which subtrees to keep."""

    def alive(self, masks: np.ndarray, cores: np.ndarray, kernels: np.ndarray) -> np.ndarray:
        """Per flat (rows of ``masks``, core slots ``cores``, kernel bases): whether its subtree may still matter."""
        ...  # pragma: no cover - protocol

    def offer(self, masks: np.ndarray) -> None:
        """Record maximal blind sets (rows of ``masks``)."""
        ...  # pragma: no cover - protocol

    def alive_hulls(self, hulls: np.ndarray) -> np.ndarray:
        """Per subtree whose every flat lies inside a row of ``hulls``: whether it may still matter."""
        ...  # pragma: no cover - protocol

    def visit(self, masks: np.ndarray, kernels: np.ndarray) -> None:
        """See every expanded flat (rows of ``masks``) with an orthonormal basis of its kernel."""
        ...  # pragma: no cover - protocol


class NodeCap(Exception):
    """The walk expanded the most flats it was allowed (``max_nodes``); the collector holds what it found."""


class _Found:
    """Orbit representatives of the maximal blind sets found, deduplicated by their bits first."""

    def __init__(self, space: SlotSpace) -> None:
        self.space = space
        self.seen: set[bytes] = set()
        self.orbits: dict[tuple[int, ...], np.ndarray] = {}

    def alive(self, masks: np.ndarray, cores: np.ndarray, kernels: np.ndarray) -> np.ndarray:
        """Every subtree may hold a new orbit: enumeration prunes nothing."""
        return np.ones(masks.shape[0], dtype=bool)

    def alive_hulls(self, hulls: np.ndarray) -> np.ndarray:
        """Every subtree may hold a new orbit: enumeration prunes nothing."""
        return np.ones(hulls.shape[0], dtype=bool)

    def visit(self, masks: np.ndarray, kernels: np.ndarray) -> None:
        """Enumeration needs only the maximal sets."""

    def offer(self, masks: np.ndarray) -> None:
        for m, packed in zip(masks, np.packbits(masks, axis=1)):
            raw = packed.tobytes()
            if raw in self.seen:
                continue
            self.seen.add(raw)
            key = self.space.orbit_key(m)
            if key not in self.orbits:
                rep = np.zeros(self.space.size, dtype=bool)
                rep[list(key)] = True
                self.orbits[key] = rep


def real_rows(rows: np.ndarray, tol: float) -> np.ndarray | None:
    """The rows in a unitary basis of the columns in which they are real, if there is one.

    For a real plant the columns of a block pair up: column ``j'`` of every
    slot is ``lambda`` times the conjugate of column ``j`` with
    ``|lambda| = 1`` (columns have unit norm), or ``j`` is such a multiple of
    its own conjugate.  Scaling ``x_j'`` by ``conj(lambda)`` and mapping the
    pair to ``(x_j + x_j') / sqrt 2`` and ``i (x_j - x_j') / sqrt 2`` (a
    self-paired column by ``conj(sqrt(lambda))``) is a unitary ``T`` with
    every row of ``r T`` real, so every rank, kernel dimension and residual
    norm is unchanged and real arithmetic does the work.  ``None`` when the
    columns do not pair within ``tol``.
    """
    L = rows.shape[2]
    cols = rows.reshape(-1, L).T
    norms = np.linalg.norm(cols, axis=1)
    T = np.zeros((L, L), dtype=complex)
    used = np.zeros(L, dtype=bool)
    k = 0
    s = 1 / np.sqrt(2)
    for j in range(L):
        if used[j]:
            continue
        if norms[j] <= tol:
            T[j, k], used[j], k = 1.0, True, k + 1
            continue
        lam = (cols @ cols[j]) / norms[j] ** 2  # x_jj = lam conj(x_j) => lam = <conj(x_j), x_jj> / |x_j|^2
        dist = np.abs(cols - lam[:, None] * cols[j].conj()[None, :]).max(axis=1)
        dist[used | (np.abs(np.abs(lam) - 1) > tol)] = np.inf
        jj = int(np.argmin(dist))
        if dist[jj] > tol:
            return None
        if jj == j:
            T[j, k], used[j], k = np.sqrt(lam[j]).conj(), True, k + 1
            continue
        T[j, k], T[jj, k] = s, s * lam[jj].conj()
        T[j, k + 1], T[jj, k + 1] = 1j * s, -1j * s * lam[jj].conj()
        used[j] = used[jj] = True
        k += 2
    out = rows @ T
    if np.abs(out.imag).max() > tol:
        return None
    return np.ascontiguousarray(out.real)


def real_space(space: SlotSpace) -> SlotSpace:
    """``space`` with real rows when a unit scalar per slot and a unitary ``T`` make them real.

    Conjugation maps the row of phase ``n`` to the row of phase ``n`` up to
    the shift ``c`` of the exponents (``-e_j = e_j' + c`` mod ``N0``), so
    multiplying phase ``n`` by ``exp(i pi c n / N0)`` (a unit scalar per
    slot: no rank, kernel or residual norm changes) leaves conjugate pairs
    of columns for :func:`real_rows`.  Tries every ``c``; ``space`` itself
    when none works.
    """
    tol = 1e-12 * max(1.0, float(np.abs(space.rows).max()))
    phases = np.repeat(np.arange(space.n_phases), space.n_groups)
    for c in range(2 * space.n_phases):
        scale = np.exp(1j * np.pi * c * phases / space.n_phases)
        real = real_rows(space.rows * scale[:, None, None], tol)
        if real is not None:
            return replace(space, rows=real)
    return space


def _residuals(W: np.ndarray, Q: np.ndarray, b: np.ndarray, e: np.ndarray, rank: np.ndarray) -> np.ndarray:
    """``||W_t N_e||`` for each pair ``(flat b, slot e)`` (rows) and every slot ``t`` (columns).

    ``N_e`` spans ``ker(W_e)``, so a residual vanishes iff ``t`` lies in
    ``cl(Q_b + e)``; one-row slots use ``||W_t - (W_t u_e^*) u_e||``, ``u_e = W_e / |W_e|``.
    """
    _, S, p, d = W.shape
    parts = []
    for part in _chunks(b.size, S * p * d):
        bb, ee = b[part], e[part]
        if p == 1:
            line = _line_residuals if np.iscomplexobj(W) else _real_line_residuals
            parts.append(line(W[bb, :, 0, :], ee))
            continue
        Wb = W[bb]
        _, _, Vh = np.linalg.svd(Wb[np.arange(bb.size), ee])
        N = Vh.conj().swapaxes(1, 2) * (np.arange(d)[None, :] >= rank[bb, ee][:, None])[:, None, :]
        parts.append(np.linalg.norm(np.einsum("ctpd,cde->ctpe", Wb, N), axis=(2, 3)))
    return np.concatenate(parts)


def _line_residuals(rows: np.ndarray, e: np.ndarray) -> np.ndarray:
    """The one-row case of :func:`_residuals`: ``||W_t - (W_t u_e^*) u_e||`` for ``rows`` of shape ``(pairs, S, d)``."""
    ue = rows[np.arange(rows.shape[0]), e]
    u = ue / np.linalg.norm(ue, axis=1)[:, None]
    coef = rows @ u.conj()[:, :, None]
    diff = rows - coef * u[:, None, :]
    arr: np.ndarray = np.sqrt(np.einsum("csd,csd->cs", diff, diff.conj()).real)
    return arr


def _real_line_residuals(rows: np.ndarray, e: np.ndarray) -> np.ndarray:
    """:func:`_line_residuals` of real rows: ``||W_t - (W_t . u_e) u_e||`` for ``rows`` of shape ``(pairs, S, d)``.

    The same floating-point operations as :func:`_line_residuals`, in the
    same order (the product ``(W_t . u_e) u_e`` formed one column at a time
    instead of by a broadcast over a length-``d`` axis, which is about half
    the cost at ``d = 2, 3``): the residuals are the same bits, which
    ``tests/search/test_residuals_same_bits.py`` checks.
    """
    ue = rows[np.arange(rows.shape[0]), e]
    u = ue / np.linalg.norm(ue, axis=1)[:, None]
    coef = (rows @ u[:, :, None])[:, :, 0]
    diff = np.empty_like(rows)
    for k in range(rows.shape[2]):
        np.multiply(coef, u[:, k, None], out=diff[:, :, k])
    np.subtract(rows, diff, out=diff)
    result: np.ndarray = np.sqrt(np.einsum("csd,csd->cs", diff, diff))
    return result


def gap_canonical_possible(space: SlotSpace, masks: np.ndarray, cores: np.ndarray) -> np.ndarray:
    """Whether some flat in each subtree can be in *gap-canonical* rotation.

    A non-empty set ``D`` is gap-canonical when, with ``g*`` the first row
    group it meets, it holds the slot ``(0, g*)`` and the cyclic gap of the
    phases of group ``g*`` that ends at phase 0 (from its last phase to
    ``N0``) is the largest gap between consecutive phases of that group:
    every shift orbit has such a rotation (start it after a largest gap).
    Descendants ``D`` of a flat ``Q`` with core ``c`` contain ``Q`` and agree
    with it on the slots ``<= c``, so a subtree is cut when

    (a) a decided slot ``(0, h)`` is missing while ``Q`` meets group ``h``
        and no earlier decided ``(0, g)`` is held (``D`` would start at a
        group ``<= h`` without its phase-0 slot), or
    (b) a gap between two decided phases of ``g*`` exceeds
        ``N0 - (last phase of g* in Q)``, which bounds the gap before
        phase 0 of every descendant from above.

    Slot ``(0, 0)`` is decided first, so most rotations are cut at the top
    of the search, where the window form of
    :func:`kfio.search._blind.canonical_possible` decides late.
    """
    C, G, N0 = masks.shape[0], space.n_groups, space.n_phases
    m3 = masks.reshape(C, N0, G)
    groups = np.arange(G)
    decided0 = groups[None, :] <= cores[:, None]
    held0 = decided0 & m3[:, 0, :]
    first = np.where(held0.any(axis=1), np.argmax(held0, axis=1), G)
    meets = m3.any(axis=1)
    ok: np.ndarray = np.logical_not((decided0 & (groups[None, :] < first[:, None]) & meets).any(axis=1))
    phases = np.arange(N0)
    for g in range(G):
        rows = np.flatnonzero(ok & (first == g))
        if rows.size == 0:
            continue
        P = m3[rows, :, g]
        dec = P & (phases[None, :] * G + g <= cores[rows, None])
        prev = np.maximum.accumulate(np.where(dec, phases[None, :], -1), axis=1)
        gaps = np.where(dec[:, 1:], phases[None, 1:] - prev[:, :-1], 0).max(axis=1, initial=0)
        last = N0 - 1 - np.argmax(P[:, ::-1], axis=1)
        ok[rows] = gaps <= N0 - last
    return ok


def _gap_canonical_children(Q: np.ndarray, b: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One group: :func:`gap_canonical_possible` of ``Q[b] + e`` with core ``e``, and its largest decided gap.

    Slots are phases.  The decided phases of ``Q[b] + e`` are those of
    ``Q[b]`` before ``e`` and ``e``, so per flat of ``Q`` the last phase
    before each ``t`` and the largest gap ending before ``t`` (running
    maxima) give every pair in a few lookups, where the general test scans
    every slot of every pair.  Phase 0 must be held (or be ``e``), and the
    largest gap at most ``N0`` minus the last phase.
    """
    C, N0 = Q.shape
    phases = np.arange(N0)
    upto = np.maximum.accumulate(np.where(Q, phases, -1), axis=1)  # last phase of Q at or before t
    prev = np.concatenate([np.full((C, 1), -1), upto[:, :-1]], axis=1)  # ... before t
    ending = np.where(Q & (phases >= 1), phases - prev, 0)  # the gap that ends at each phase of Q
    widest = np.maximum.accumulate(ending, axis=1)
    widest_before = np.concatenate([np.zeros((C, 1), dtype=widest.dtype), widest[:, :-1]], axis=1)
    gap = np.maximum(widest_before[b, e], np.where(e >= 1, e - prev[b, e], 0))
    ok = (Q[b, 0] | (e == 0)) & (gap <= N0 - np.maximum(upto[b, -1], e))
    return ok, gap


def _expand(
    space: SlotSpace,
    masks: np.ndarray,
    cores: np.ndarray,
    K: np.ndarray,
    margins: Margins,
    found: Collector,
    affine: Affine | None = None,
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Expand a batch of flats sharing a kernel dimension; return the child batches to expand.

    With ``affine`` (one group) the flats kept are those that may be
    lex-first in their affine orbit (:mod:`kfio.search._affine`) instead of
    gap-canonical.
    """
    index = np.arange(space.size)
    d = K.shape[2]
    S, p, L = space.rows.shape
    W = (space.rows.reshape(1, S * p, L) @ K).reshape(K.shape[0], S, p, d)
    if W.shape[2] == 1:
        sv = np.linalg.norm(W[:, :, 0, :], axis=2)[:, :, None]
    else:
        sv = np.linalg.svd(W, compute_uv=False)
    rank = (~margins.record(sv)).sum(axis=2)
    Q = masks | (rank == 0)
    blind_ext = ~Q & (rank < d)
    found.visit(Q, K)
    found.offer(Q[~blind_ext.any(axis=1)])
    b, e = np.nonzero(blind_ext & (index[None, :] > cores[:, None]))
    # The closure only adds slots after e (or fails prefix preservation), and
    # the gap-canonical test only cuts more as slots are added: a pair cut with
    # Q + e in place of its closure is cut for good, before any residual.
    grown = Q[b]
    grown[np.arange(b.size), e] = True
    # Every flat below cl(Q + e) holds Q + e, agrees with it up to e, and is
    # blind, so each slot it adds after e is a blind extension of Q: its hull.
    later = blind_ext[b] & (index[None, :] > e[:, None])
    early = found.alive_hulls(grown | later)
    b, e, grown, later = b[early], e[early], grown[early], later[early]
    one = space.n_groups == 1
    if affine is not None:
        early = affine.pairs_possible(Q, b, e)
    elif one:
        early, gap = _gap_canonical_children(Q, b, e)
        gap = gap[early]
    else:
        early = gap_canonical_possible(space, grown, e)
    b, e, later = b[early], e[early], later[early]
    if b.size == 0:
        return []
    closures = margins.record(_residuals(W, Q, b, e, rank)) | Q[b]
    new = closures & ~Q[b]
    ppc = ~(new & (index[None, :] < e[:, None])).any(axis=1)
    b, e, closures, later = b[ppc], e[ppc], closures[ppc], later[ppc]
    dims = d - rank[b, e]
    if affine is not None:
        # The size test first, and the lex-first test (a product with every map) only on the
        # children to expand: a maximal child offered needlessly costs the collector one key.
        canonical = found.alive_hulls(closures | later)
        test = canonical & (dims > 1)
        canonical[test] = affine.lex_first_possible(closures[test], e[test])
    elif one:
        # The closure adds slots after e only: the decided gaps stay, the last phase moves.
        last = space.size - 1 - np.argmax(closures[:, ::-1], axis=1)
        canonical = gap[ppc] <= space.size - last
    else:
        canonical = gap_canonical_possible(space, closures, e)
    keep = canonical & found.alive_hulls(closures | later)
    found.offer(closures[keep & (dims == 1)])
    inner = np.flatnonzero(keep & (dims > 1))
    if inner.size == 0:
        return []
    b, e, closures, cut_rank = b[inner], e[inner], closures[inner], rank[b[inner], e[inner]]
    _, _, vh = np.linalg.svd(W[b, e])
    out = []
    for r in np.unique(cut_rank)[::-1]:
        sel = cut_rank == r
        Kc = K[b[sel]] @ vh[sel, r:, :].conj().swapaxes(1, 2)
        out.append((closures[sel], e[sel], Kc))
    return out


def walk(
    space: SlotSpace,
    budget: Budget,
    margins: Margins,
    found: Collector,
    max_nodes: int | None = None,
    affine: Affine | None = None,
) -> int:
    """Batched closure extension over gap-canonical flats, offering maximal blind sets to ``found``.

    With ``affine`` (one group whose matroid the maps of
    :class:`~kfio.search._affine.Affine` preserve) the walk keeps the flats
    that may be lex-first in their affine orbit instead: every orbit is
    still met, by its lex-first flat.

    ``found.alive_hulls`` may prune subtrees (a branch and bound) from a
    superset of every flat below a child (its hull), asked before any
    residual of a new pair and again once its closure is known;
    ``found.alive`` is asked when a batch leaves the stack.  Returns the
    number of flats expanded.

    Raises
    ------
    BudgetExceeded
        When ``budget`` runs out (one tick per expanded flat).
    NodeCap
        When more than ``max_nodes`` flats would be expanded.
    """
    start = root(space, margins)
    stack = [(start.mask[None, :], np.array([start.core]), np.eye(space.n_columns, dtype=space.rows.dtype)[None, :, :])]
    nodes = 0
    while stack:
        masks, cores, K = stack.pop()
        limit = max(1, min(_BATCH, _ENTRIES // max(1, space.size * space.size * K.shape[2])))
        if masks.shape[0] > limit:
            stack.append((masks[limit:], cores[limit:], K[limit:]))
            masks, cores, K = masks[:limit], cores[:limit], K[:limit]
        live = found.alive(masks, cores, K)
        if not live.all():
            masks, cores, K = masks[live], cores[live], K[live]
            if masks.shape[0] == 0:
                continue
        budget.tick("sigma: closure search", masks.shape[0])
        nodes += masks.shape[0]
        if max_nodes is not None and nodes > max_nodes:
            raise NodeCap(f"more than {max_nodes} flats")
        stack.extend(_expand(space, masks, cores, K, margins, found, affine))
    return nodes


def enumerate_orbits(space: SlotSpace, budget: Budget, margins: Margins) -> SearchResult:
    """Every shift orbit of maximal blind sets, by batched closure extension.

    The same flats, rank calls and orbits as
    ``search(space, budget, margins)`` without an objective;
    :attr:`SearchResult.maximal` lists one representative per orbit in
    the order of their keys.

    Raises
    ------
    BudgetExceeded
        When ``budget`` runs out (one tick per expanded flat).
    """
    space = real_space(space)
    W_len = space.window(margins)
    found = _Found(space)
    nodes = walk(space, budget, margins, found)
    maximal = tuple(found.orbits[k] for k in sorted(found.orbits))
    return SearchResult(maximal=maximal, nodes=nodes, planes=0, window=W_len)
