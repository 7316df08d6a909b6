"""Maximal blind sets of a phase block, by closures (Rohr, Marelli and Fu (2014), Lemma 3).

A set ``F`` of slots ``(n, g)`` (phase ``n`` in ``[0, N0)``, row group ``g``)
is *blind* when the stacked rows ``r_n[g] = C_hat[g] diag(omega^n)`` lack full
column rank ``L`` (docs/theory.md, section 2).  Equivalently some ``v != 0`` has
``r_n[g] v = 0`` on all of ``F``: maximal blind sets are maximal *zero sets*
``Z(v)``, i.e. closed sets (flats) ``cl(F) = {slots killing ker F}``.  A flat
of rank ``k < L`` is the closure of at most ``k`` slots, so the search walks
flats, never the ``2^(N0 G)`` subsets:

* **prefix-preserving closure extension** (LCM: Uno, Asai, Uchida and
  Arimura 2004): a flat ``Q`` with core slot ``c`` has the children ``cl(Q + e)``,
  ``e > c``, that add nothing below ``e``; every flat is reached once.  A node
  keeps an orthonormal basis ``K`` of its kernel and tests all extensions at
  once (``W = r K``, one batched product).  A child whose kernel is a line
  is maximal and is scored without being expanded; under branch and bound
  the children whose kernel is a plane are resolved together in one batch
  (:func:`plane_leaves`);
* **shift orbits**: ``r_{n+1} = r_n diag(omega)``, so ``F + 1`` is blind iff
  ``F`` is.  Let a *window* be ``W`` consecutive phases (all groups), ``W``
  the fewest phases of full rank.  Only flats in *canonical rotation* are
  kept: no window misses fewer slots than the window at phase 0.  A prefix
  that already rules this out is cut (the missed slots of window 0 that are
  decided bound it from below, the misses of ``Q`` bound every window from
  above);
* **window bound** (the idea of the Brouwer-Zimmermann minimum-distance
  algorithm): every slot lies in ``W`` windows, so a set missing ``w`` slots
  has a window missing at most ``floor(W w / N0)``.  With an incumbent, a set
  can only beat it by missing at most ``w_max`` slots, so canonical window 0
  misses at most ``j = floor(W w_max / N0)``: the search only grows flats from
  nearly full window-0 prefixes.  For seed-type blocks (``N0 = 60``,
  ``L = 8``, largest blind set 36) that is ``j = 3``.  An objective may
  sharpen ``j`` (:attr:`Objective.window_misses`): in canonical rotation
  every window misses at least as much as window 0, which the Markov
  objective of :mod:`kfio.sigma._sigma` turns into a bound on the score;
* **branch and bound** for a monotone score (``rho(M_F)`` is monotone in
  ``F``): a subtree lies inside its *hull* (the flat plus the later slots
  whose closure with the parent is still blind and keeps the prefix), so a
  hull that cannot beat the incumbent cuts the subtree.

Ranks are numerical; :class:`Margins` records the closest calls so that the
caller can report them and confirm the decisions that matter exactly.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from .._budget import Budget
from ..structure import PhaseBlock, Slot

#: Batched monotone score: boolean masks ``(C, S)`` -> values ``(C,)``.
Score = Callable[[np.ndarray], np.ndarray]

#: Relative margin under which a bound counts as beating the incumbent; it
#: keeps float round-off in the score from cutting a truly better subtree.
_BOUND_SLACK = 1e-12

#: Most complex entries one batched step may hold (about 64 MB).
_CHUNK_ENTRIES = 1 << 22


def _chunks(n: int, per_item: int) -> list[slice]:
    """Slices of ``range(n)`` whose batches hold at most :data:`_CHUNK_ENTRIES` entries."""
    step = max(1, _CHUNK_ENTRIES // max(1, per_item))
    return [slice(i, i + step) for i in range(0, n, step)]


@dataclass(frozen=True)
class Objective:
    """What branch and bound maximizes.

    Attributes
    ----------
    score:
        Monotone under inclusion (a superset scores at least as high).
    max_weight:
        Given the incumbent's score, the largest number of slots a set may
        miss and still score higher (drives the window bound).
    window_misses:
        Optional: given the incumbent's score, ``W`` and the fewest slots a
        window of the incumbent misses (a ``c`` known to be possible), the
        largest ``c`` such that a set whose every window misses at least
        ``c`` slots may still score as high (``None``: no sharper than
        ``max_weight``).  A sharper window bound than averaging
        ``max_weight`` over the windows.
    enough:
        Optional: a score no set exceeds (proved elsewhere, e.g.
        :func:`kfio.search._cyclic.largest_blind_bound`).  The search stops
        once the incumbent reaches it; the incumbent only changes to a
        strictly higher score, so the set returned is the one the full
        search returns.  Only without ``window_misses``.
    """

    score: Score
    max_weight: Callable[[float], int]
    window_misses: Callable[[float, int, int], int | None] | None = None
    enough: float | None = None


@dataclass
class Margins:
    """The closest numerical rank calls of a search.

    Attributes
    ----------
    tol:
        Threshold: singular values and residuals ``<= tol`` count as zero.
    largest_zero:
        Largest value that was treated as zero.
    smallest_nonzero:
        Smallest value that was treated as non-zero.
    """

    tol: float
    largest_zero: float = 0.0
    smallest_nonzero: float = float("inf")

    def record(self, values: np.ndarray) -> np.ndarray:
        """Classify ``values`` as zero (``True``) or not, remembering the margins."""
        zero = values <= self.tol
        if zero.size:
            # The same extremes as values[zero].max() and values[~zero].min(), without the two
            # compacting copies (a NaN is not zero and, as there, leaves the smallest unchanged).
            self.largest_zero = max(self.largest_zero, float(np.where(zero, values, -np.inf).max()))
            self.smallest_nonzero = min(self.smallest_nonzero, float(np.where(zero, np.inf, values).min()))
        return zero

    @property
    def clear(self) -> bool:
        """Whether every decision was at least ``1e3`` times away from ``tol``."""
        return self.largest_zero <= 1e-3 * self.tol and self.smallest_nonzero >= 1e3 * self.tol


@dataclass(frozen=True)
class SlotSpace:
    """The ground set ``[0, N0) x groups`` of a :class:`PhaseBlock` as row blocks.

    Slot ``(n, g)`` has index ``i = n * G + g``; ``rows[i]`` holds its rows of
    ``r_n`` zero-padded to the largest group (zero rows change no rank).
    """

    n_phases: int
    n_groups: int
    rows: np.ndarray
    tol: float

    @classmethod
    def from_block(cls, block: PhaseBlock, rtol: float = 1e-9) -> SlotSpace:
        """Rows of every base slot; ``tol = rtol * max(1, largest slot norm)``."""
        G, N0, L = len(block.row_groups), block.base_period, block.n_columns
        width = max(len(rows) for rows in block.row_groups)
        rows = np.zeros((N0 * G, width, L), dtype=complex)
        for n in range(N0):
            for g in range(G):
                r = block.rows(n, g)
                rows[n * G + g, : r.shape[0]] = r
        scale = max(1.0, max(float(np.linalg.norm(r, 2)) for r in rows))
        return cls(n_phases=N0, n_groups=G, rows=rows, tol=rtol * scale)

    @property
    def size(self) -> int:
        """``S = N0 * G``, the number of base slots."""
        return int(self.rows.shape[0])

    @property
    def n_columns(self) -> int:
        """``L``."""
        return int(self.rows.shape[2])

    def slots(self, mask: np.ndarray) -> list[Slot]:
        """The ``(n, g)`` slots of a boolean mask."""
        return [divmod(int(i), self.n_groups) for i in np.flatnonzero(mask)]

    def mask(self, slots: list[Slot]) -> np.ndarray:
        """Boolean mask of base slots (phases taken modulo ``N0``)."""
        out = np.zeros(self.size, dtype=bool)
        for n, g in slots:
            out[(n % self.n_phases) * self.n_groups + g] = True
        return out

    def rank(self, mask: np.ndarray, margins: Margins) -> int:
        """Numerical rank of the stacked rows of ``mask``."""
        M = self.rows[mask].reshape(-1, self.n_columns)
        if M.shape[0] == 0:
            return 0
        return int((~margins.record(np.linalg.svd(M, compute_uv=False))).sum())

    def spanning_subset(self, mask: np.ndarray, margins: Margins) -> np.ndarray:
        """Greedy slots of ``mask`` whose rows span the rows of all of ``mask``."""
        keep = np.zeros(self.size, dtype=bool)
        rank = 0
        for i in np.flatnonzero(mask):
            keep[i] = True
            r = self.rank(keep, margins)
            keep[i] = r > rank
            rank = r
        return keep

    def window(self, margins: Margins) -> int:
        """``W``: the fewest consecutive phases whose slots have full rank (``N0`` if none)."""
        for W in range(1, self.n_phases):
            if self.rank(np.arange(self.size) < W * self.n_groups, margins) == self.n_columns:
                return W
        return self.n_phases

    def fewest_window_misses(self, mask: np.ndarray, W: int) -> int:
        """The fewest slots of ``mask``'s complement in any ``W`` consecutive phases (cyclically)."""
        misses = self.n_groups - mask.reshape(self.n_phases, self.n_groups).sum(axis=1)
        return int(min(np.roll(misses, -k)[:W].sum() for k in range(self.n_phases)))

    def rotate(self, mask: np.ndarray, k: int) -> np.ndarray:
        """The mask of ``F + k`` (phases shifted by ``k`` modulo ``N0``)."""
        return np.roll(mask, k * self.n_groups, axis=-1)

    def orbit_key(self, mask: np.ndarray) -> tuple[int, ...]:
        """Canonical key of a shift orbit: its smallest sorted index tuple.

        Computed with integer bit rotations: with slot ``i`` at bit
        ``S - 1 - i``, rotating the phases by ``k`` rotates the integer right
        by ``k G`` bits, and among sets of one size the lexicographically
        smallest index tuple is the largest integer.  Equal to
        :meth:`orbit_key_reference`, about 30 times faster.
        """
        S, G = self.size, self.n_groups
        pad = (-S) % 8
        x = int.from_bytes(np.packbits(mask).tobytes(), "big") >> pad
        full = (1 << S) - 1
        best, best_k = x, 0
        for k in range(1, self.n_phases):
            s = k * G
            y = ((x >> s) | (x << (S - s))) & full
            if y > best:
                best, best_k = y, k
        return tuple(int(i) for i in np.flatnonzero(self.rotate(mask, best_k)))

    def orbit_key_reference(self, mask: np.ndarray) -> tuple[int, ...]:
        """:meth:`orbit_key` by sorting every rotation's index tuple (the previous route, a test oracle)."""
        return min(tuple(int(i) for i in np.flatnonzero(self.rotate(mask, k))) for k in range(self.n_phases))


def group_space(space: SlotSpace, g: int) -> SlotSpace:
    """The slots of group ``g`` alone, as a one-group space (same tolerance)."""
    rows = space.rows[g :: space.n_groups]
    return SlotSpace(n_phases=space.n_phases, n_groups=1, rows=np.ascontiguousarray(rows), tol=space.tol)


@dataclass
class Flat:
    """A node of the closure search.

    The kernel is ``basis @ ker(cut)`` (an orthonormal ``L x d`` matrix), kept
    as the parent's kernel and the cut rows until the node is expanded, so
    children that are never expanded cost no factorization.
    """

    mask: np.ndarray
    core: int
    basis: np.ndarray
    cut: np.ndarray
    cut_rank: int

    def kernel(self) -> np.ndarray:
        """Orthonormal basis of the common kernel of the rows of :attr:`mask`."""
        if self.cut_rank == 0:
            return self.basis
        _, _, vh = np.linalg.svd(self.cut)
        values_out: np.ndarray = self.basis @ vh[self.cut_rank :].conj().T
        return values_out


@dataclass(frozen=True)
class Expansion:
    """Everything one batched step learns about a flat ``Q`` (children are rows).

    Attributes
    ----------
    mask:
        ``Q`` itself, with any slot that kills its kernel included.
    maximal:
        No slot outside ``Q`` keeps it blind: ``Q`` is a maximal blind set.
    kernel:
        Orthonormal basis ``K`` of the kernel of ``Q``.
    cores, masks, hulls, dims:
        Per prefix-preserving child: its core slot, its mask, a superset of
        every flat in its subtree, and its kernel dimension (1 = maximal).
    cuts, cut_ranks:
        Per child, the rows ``W_e = r_e K`` that cut its kernel out of ``K``.
    """

    mask: np.ndarray
    maximal: bool
    kernel: np.ndarray
    cores: np.ndarray
    masks: np.ndarray
    hulls: np.ndarray
    dims: np.ndarray
    cuts: np.ndarray
    cut_ranks: np.ndarray


def root(space: SlotSpace, margins: Margins) -> Flat:
    """``cl(empty)``: the slots whose rows vanish; the kernel is everything."""
    zero = margins.record(np.linalg.norm(space.rows.reshape(space.size, -1), axis=1))
    L = space.n_columns
    return Flat(mask=zero, core=-1, basis=np.eye(L, dtype=complex), cut=np.zeros((0, L)), cut_rank=0)


def _closure_residuals(W: np.ndarray, later: np.ndarray, ranks: np.ndarray) -> np.ndarray:
    """``||W_t N_e||`` for every slot ``t`` (columns) and each ``e`` in ``later`` (rows).

    ``N_e`` is an orthonormal basis of ``ker(W_e)``, so the residual vanishes
    iff ``t`` lies in ``cl(Q + e)``.  One-row slots need no factorization:
    ``||W_t N_e|| = ||W_t - (W_t u_e^*) u_e||`` with ``u_e = W_e / |W_e|``.
    """
    S, p, d = W.shape
    parts = []
    for part in _chunks(later.size, S * p * d):
        e = later[part]
        if p == 1:
            rows = W[:, 0, :]
            u = rows[e] / np.linalg.norm(rows[e], axis=1)[:, None]
            coef = rows @ u.conj().T
            parts.append(np.linalg.norm(rows[None, :, :] - coef.T[:, :, None] * u[:, None, :], axis=2))
            continue
        _, _, Vh = np.linalg.svd(W[e])
        N = Vh.conj().swapaxes(1, 2) * (np.arange(d)[None, :] >= ranks[e][:, None])[:, None, :]
        parts.append(np.linalg.norm(np.einsum("tpd,cde->ctpe", W, N), axis=(2, 3)))
    return np.concatenate(parts)


def expand(space: SlotSpace, flat: Flat, margins: Margins) -> Expansion:
    """Test every one-slot extension of ``flat`` at once.

    With ``W_e = r_e K`` (``K`` the kernel basis, ``d`` columns), ``Q + e`` is
    blind iff ``rank W_e < d``; its kernel is ``K ker(W_e)`` and its closure
    is the set of slots ``t`` with ``W_t P_e = 0``.
    """
    Q, K = flat.mask, flat.kernel()
    d, index = K.shape[1], np.arange(space.size)
    W = space.rows @ K
    if W.shape[1] == 1:
        sv = np.linalg.norm(W[:, 0, :], axis=1)[:, None]
    else:
        sv = np.linalg.svd(W, compute_uv=False)
    rank = (~margins.record(sv)).sum(axis=1)
    # A slot killing the kernel belongs to the flat; re-deciding it here keeps
    # every later step consistent with this node's own rank calls.
    Q = Q | (rank == 0)
    blind_ext = ~Q & (rank < d)
    later = np.flatnonzero(blind_ext & (index > flat.core))
    if later.size == 0:
        none = np.zeros(0, dtype=int)
        return Expansion(
            Q,
            not blind_ext.any(),
            K,
            none,
            np.zeros((0, space.size), bool),
            np.zeros((0, space.size), bool),
            none,
            W[none],
            none,
        )
    closures = margins.record(_closure_residuals(W, later, rank)) | Q[None, :]
    new = closures & ~Q[None, :]
    candidates = np.zeros(space.size, dtype=bool)
    candidates[later[~new[:, : flat.core + 1].any(axis=1)]] = True
    ppc = ~(new & (index[None, :] < later[:, None])).any(axis=1)
    cores = later[ppc]
    hulls = closures[ppc] | (candidates[None, :] & (index[None, :] > cores[:, None]))
    return Expansion(
        mask=Q,
        maximal=not blind_ext.any(),
        kernel=K,
        cores=cores,
        masks=closures[ppc],
        hulls=hulls,
        dims=d - rank[cores],
        cuts=W[cores],
        cut_ranks=rank[cores],
    )


def plane_leaves(space: SlotSpace, exp: Expansion, children: np.ndarray, margins: Margins) -> np.ndarray:
    """Every maximal blind set above the given children, all of whose kernels are planes.

    Above a flat ``Q`` with a 2-dimensional kernel ``K2`` the maximal blind
    sets are ``Q`` plus the slots ``s`` with ``v_s n_t = 0``, one per slot
    ``t`` of rank 1 (``v = r K2``, ``n_t`` spanning ``ker v_t``), or ``Q``
    itself if there is no such ``t``.  Batched over children, slots and
    slots, this replaces one expansion per plane (branch and bound only: a
    maximal set may come out several times).
    """
    per_child = space.size**2 * space.rows.shape[1]
    return np.concatenate(
        [_plane_leaves(space, exp, children[part], margins) for part in _chunks(children.size, per_child)]
    )


def _plane_leaves(space: SlotSpace, exp: Expansion, children: np.ndarray, margins: Margins) -> np.ndarray:
    _, _, vh = np.linalg.svd(exp.cuts[children])
    K2 = exp.kernel[None, :, :] @ vh[:, -2:, :].conj().swapaxes(1, 2)
    V = space.rows[None, :, :, :] @ K2[:, None, :, :]
    if V.shape[2] == 1:
        v = V[:, :, 0, :]
        size = np.linalg.norm(v, axis=2)
        rank1 = ~margins.record(size)
        null = np.stack([v[:, :, 1], -v[:, :, 0]], axis=2) / np.maximum(size, 1e-300)[:, :, None]
    else:
        _, sv, vt = np.linalg.svd(V)
        rank1 = (~margins.record(sv)).sum(axis=2) == 1
        null = vt[:, :, 1, :].conj()
    killed = margins.record(np.linalg.norm(np.einsum("cspk,ctk->ctsp", V, null), axis=3))
    masks = exp.masks[children]
    leaves = (killed | masks[:, None, :])[rank1]
    return np.concatenate([leaves, masks[~rank1.any(axis=1)]])


def canonical_possible(space: SlotSpace, W: int, masks: np.ndarray, cores: np.ndarray, j_max: int) -> np.ndarray:
    """Whether some flat in each subtree can be in canonical rotation and miss ``<= j_max`` of window 0.

    Descendants of a flat agree with it up to its core, so the slots of
    window 0 up to the core that it misses are missed for good (a lower
    bound ``c0``), while the slots it holds are held by every descendant, so
    its misses per window bound theirs from above.
    """
    C, G, WG = masks.shape[0], space.n_groups, W * space.n_groups
    decided = np.minimum(cores, WG - 1)
    held = np.cumsum(masks[:, :WG], axis=1)[np.arange(C), decided]
    c0 = decided + 1 - held
    misses = G - masks.reshape(C, space.n_phases, G).sum(axis=2)
    wrapped = np.concatenate([np.zeros((C, 1), dtype=int), misses, misses[:, : W - 1]], axis=1).cumsum(axis=1)
    per_window = wrapped[:, W : W + space.n_phases] - wrapped[:, : space.n_phases]
    arr: np.ndarray = (c0 <= j_max) & (per_window.min(axis=1) >= c0)
    return arr


@dataclass(frozen=True)
class SearchResult:
    """Outcome of a closure search.

    Attributes
    ----------
    maximal:
        Maximal blind sets found: every shift orbit once when enumerating,
        only the best one under branch and bound.
    nodes:
        Flats expanded.
    planes:
        Flats with a 2-dimensional kernel resolved in batch (:func:`plane_leaves`).
    window:
        ``W``, the window length used for canonical rotation.
    checked:
        Flats of one group checked by the two-group front proof
        (:mod:`kfio.search._pareto_proof`), ``None`` when the walk finished alone.
    stopped:
        Branch and bound stopped at :attr:`Objective.enough`, reached by the set found.
    """

    maximal: tuple[np.ndarray, ...]
    nodes: int
    planes: int
    window: int
    checked: int | None = None
    stopped: bool = False


@dataclass
class _Incumbent:
    """Best maximal blind set so far (branch and bound) or every orbit found (enumeration)."""

    space: SlotSpace
    objective: Objective | None
    mask: np.ndarray | None = None
    value: float = -np.inf
    found: dict[tuple[int, ...], np.ndarray] = field(default_factory=dict)
    _j: tuple[float, int, int] | None = None  # (incumbent value, W, j_max) of the last j_max call

    def beats(self, bound: float) -> bool:
        """Whether nothing scoring at most ``bound`` can beat the incumbent."""
        return bool(self.beats_all(np.array([bound]))[0])

    def beats_all(self, bounds: np.ndarray) -> np.ndarray:
        """:meth:`beats` for each of ``bounds``."""
        return bounds < self.value - _BOUND_SLACK * max(1.0, abs(self.value))

    def max_misses(self) -> int:
        """Most slots a set may miss and still beat the incumbent (all of them if there is none)."""
        if self.objective is None or not np.isfinite(self.value):
            return self.space.size
        return self.objective.max_weight(self.value)

    def j_max(self, W: int) -> int:
        """Most misses canonical window 0 of a set that beats the incumbent may have.

        Every slot lies in ``W`` windows, so a set missing ``w`` slots has a
        window missing at most ``floor(W w / N0)``; canonical window 0 misses
        the fewest.  :attr:`Objective.window_misses` may sharpen this: in
        canonical rotation every window misses at least as many slots as
        window 0.
        """
        j = W * self.max_misses() // self.space.n_phases
        if self.objective is None or self.mask is None or self.objective.window_misses is None:
            return j
        if self._j is None or self._j[:2] != (self.value, W):
            sharper = self.objective.window_misses(self.value, W, self.space.fewest_window_misses(self.mask, W))
            self._j = (self.value, W, j if sharper is None else min(j, sharper))
        return self._j[2]

    def promising(self, masks: np.ndarray) -> np.ndarray:
        """Rows that miss few enough slots to beat the incumbent (a cheap test before scoring)."""
        result: np.ndarray = self.space.size - masks.sum(axis=1) <= self.max_misses()
        return result

    def offer(self, masks: np.ndarray) -> None:
        """Record maximal blind sets (rows of ``masks``)."""
        if self.objective is None:
            for m in masks:
                key = self.space.orbit_key(m)
                self.found.setdefault(key, np.isin(np.arange(self.space.size), key))
            return
        masks = masks[self.promising(masks)]
        if masks.shape[0] == 0:
            return
        values = self.objective.score(masks)
        i = int(np.argmax(values))
        if values[i] > self.value:
            self.mask, self.value = masks[i], float(values[i])


def _child(exp: Expansion, c: int) -> Flat:
    return Flat(exp.masks[c], int(exp.cores[c]), exp.kernel, exp.cuts[c], int(exp.cut_ranks[c]))


def _walk(
    space: SlotSpace, budget: Budget, margins: Margins, objective: Objective | None, W: int, floor: float | None
) -> tuple[_Incumbent, int, int]:
    """The depth-first walk of :func:`search`; ``floor``: start as if a set of that score were known."""
    best = _Incumbent(space, objective)
    if floor is not None:
        best.value = floor
    stack: list[tuple[Flat, float]] = [(root(space, margins), np.inf)]
    nodes = resolved = 0
    while stack:
        if objective is not None and objective.enough is not None and best.value >= objective.enough:
            break  # nothing scores higher: the rest of the walk could not change the incumbent
        flat, bound = stack.pop()
        if best.beats(bound):
            continue
        budget.tick("sigma: closure search")
        nodes += 1
        exp = expand(space, flat, margins)
        if exp.maximal:
            best.offer(exp.mask[None, :])
        keep = canonical_possible(space, W, exp.masks, exp.cores, best.j_max(W))
        best.offer(exp.masks[keep & (exp.dims == 1)])
        inner = keep & (exp.dims > 1) & best.promising(exp.hulls)
        if objective is None:
            stack.extend((_child(exp, c), np.inf) for c in np.flatnonzero(inner)[::-1])
            continue
        bounds = np.full(exp.cores.size, -np.inf)
        bounds[inner] = objective.score(exp.hulls[inner]) if inner.any() else []
        planes = np.flatnonzero(inner & (exp.dims == 2) & ~best.beats_all(bounds))
        if planes.size:
            budget.tick("sigma: closure search", planes.size)
            resolved += planes.size
            best.offer(plane_leaves(space, exp, planes, margins))
        deeper = np.flatnonzero(inner & (exp.dims > 2))
        # Ascending push order: the most promising child is expanded first.
        stack.extend((_child(exp, c), float(bounds[c])) for c in deeper[np.argsort(bounds[deeper], kind="stable")])
    return best, nodes, resolved


def search(space: SlotSpace, budget: Budget, margins: Margins, objective: Objective | None = None) -> SearchResult:
    """Depth-first closure search over flats in canonical rotation.

    Parameters
    ----------
    objective:
        ``None`` enumerates every maximal blind set (one per shift orbit);
        otherwise branch and bound returns one maximal blind set of largest
        score.  With :attr:`Objective.enough`, a walk that keeps only the
        sets reaching it runs first, and the search stops when it finds
        one: the same set as the full walk returns (tested against it).

    Enumeration walks flats one at a time;
    :func:`kfio.search._blind_batch.enumerate_orbits` finds the same
    orbits in batches, and this walk is its test oracle.

    Raises
    ------
    BudgetExceeded
        When ``budget`` runs out (one tick per expanded or resolved flat).
    """
    W = space.window(margins)
    if objective is not None and objective.enough is not None:
        assert objective.window_misses is None  # its bound depends on the incumbent's set, not only its score
        # First only the sets that reach the bound: every test below is monotone in the
        # incumbent's score, so this walk visits part of the full walk's flats in the same
        # order and meets the full walk's first set of the top score, if it reaches the bound.
        floor = objective.enough - 1e-9 * max(1.0, abs(objective.enough))
        best, nodes, resolved = _walk(space, budget, margins, objective, W, floor)
        if best.mask is not None:
            return SearchResult(maximal=(best.mask,), nodes=nodes, planes=resolved, window=W, stopped=True)
    best, nodes, resolved = _walk(space, budget, margins, objective, W, None)
    if objective is None:
        found = tuple(best.found[k] for k in sorted(best.found))
        return SearchResult(maximal=found, nodes=nodes, planes=0, window=W)
    assert best.mask is not None  # some maximal blind set has a canonical rotation
    return SearchResult(maximal=(best.mask,), nodes=nodes, planes=resolved, window=W)
