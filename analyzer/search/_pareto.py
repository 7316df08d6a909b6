"""Undominated miss vectors of maximal blind sets, by a Pareto branch and bound.

With independent Bernoulli sensors (one per row group) a maximal blind set
``F`` enters every result only through its miss vector ``z(F)``, ``z_g`` the
phases of ``[0, N0)`` at which group ``g`` is not in ``F``:
``rho(P_F) = prod_g (1 - lambda_g)^{z_g}`` (Rohr, Marelli and Fu (2014),
Corollary 2) is strictly decreasing in every ``z_g``, so ``sigma`` and every
stability region depend only on the componentwise-minimal (undominated)
miss vectors, whatever the arrival probabilities.  This module finds those
vectors without enumerating every shift orbit of maximal blind sets.

The walk is the batched closure search of :mod:`kfio.search._blind_batch`
(prefix-preserving closure extension, flats in gap-canonical rotation),
with a *front* of the undominated vectors found so far in place of the
list of every orbit:

* **decided slots**: the flats below a flat with core slot ``c`` agree
  with it on the slots ``<= c``, so the slots ``<= c`` it misses are missed
  by every set in its subtree, a lower bound ``b`` on their ``z``; the
  subtree is cut when every ``z >= b`` is dominated by or equal to a vector
  of the front;
* **one-group bounds**: ``z_g(D) >= m_g``, ``m_g`` the fewest misses of any
  blind set of group ``g`` alone (a subset of a blind set is blind), from
  the one-group branch and bound of :func:`kfio.search._blind.search`
  (that largest set, closed over every group, also seeds the front).

Every vector of the final front is attained by a maximal blind set found in
the walk, and every maximal blind set in gap-canonical rotation either was
offered to the front or lies in a cut subtree, whose sets all have vectors
dominated by or equal to one of the front: the front is exactly the set of
undominated miss vectors, each with one representative set (the first one
found).  The test oracles are the enumeration of every orbit
(:func:`kfio.search._blind_batch.enumerate_orbits`) followed by
:func:`kfio.sigma._sigma.undominated`, and all subsets of small blocks.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .._budget import Budget
from ..errors import BudgetExceeded
from ._blind import Margins, Objective, SearchResult, SlotSpace, group_space, search

#: Flats the walk over both groups may expand before a two-group front is
#: completed from the big flats of one group (:mod:`kfio.search._pareto_proof`).
#: 0: two groups go straight to the proof (docs/structure.md: faster on every
#: bench block and on 150 random ones, within 10 ms where it is not);
#: ``None``: the walk alone, to its end.
PROBE_FLATS: int | None = 0


#: Largest grid of miss vectors for which :meth:`Front.dead` looks its answer up in a table.
_TABLE_ENTRIES = 1 << 22


class Front:
    """Undominated miss vectors found so far, one representative mask each.

    Parameters
    ----------
    space:
        The slot space (``N0`` phases, ``G`` groups).
    lower:
        ``m_g``: no blind set misses fewer than ``m_g`` slots of group ``g``.
    """

    def __init__(self, space: SlotSpace, lower: np.ndarray) -> None:
        self.space = space
        self.lower = lower
        self.vectors = np.zeros((0, space.n_groups), dtype=int)
        self.masks: list[np.ndarray] = []
        self._table_of: np.ndarray | None = None
        self._dead_table: np.ndarray | None = None
        self._escape_of: np.ndarray | None = None
        self._escape: np.ndarray = np.zeros(0, dtype=int)

    def copy(self) -> Front:
        """A front with the same vectors and representative sets; offers to either leave the other as it is."""
        out = Front(self.space, self.lower)
        out.vectors = self.vectors.copy()
        out.masks = [m.copy() for m in self.masks]
        return out

    def misses(self, masks: np.ndarray) -> np.ndarray:
        """``z`` per row of ``masks``: per group, the phases not held."""
        C = masks.shape[0]
        values_out: np.ndarray = self.space.n_phases - masks.reshape(C, self.space.n_phases, self.space.n_groups).sum(
            axis=1
        )
        return values_out

    def dead(self, bounds: np.ndarray) -> np.ndarray:
        """Rows ``b`` of ``bounds`` such that every ``z >= b`` is dominated by or equal to a front vector."""
        if self.vectors.shape[0] == 0:
            return np.zeros(bounds.shape[0], dtype=bool)
        b = np.maximum(bounds, self.lower[None, :])
        table = self._table()
        if table is not None:
            # Row-major position of each vector in the grid: one lookup per row.
            side = self.space.n_phases + 1
            strides = side ** np.arange(self.space.n_groups - 1, -1, -1)
            return np.asarray(table.ravel()[np.minimum(b, self.space.n_phases) @ strides])
        return np.asarray((b[:, None, :] >= self.vectors[None, :, :]).all(axis=2).any(axis=1))

    def _table(self) -> np.ndarray | None:
        """The dominated-or-equal region of the front on the grid ``[0, N0]^G`` (``None``: grid too large).

        ``z`` is dominated by or equal to a front vector ``v`` iff ``z >= v``
        componentwise: the union of the upper orthants of the vectors, one
        running ``or`` along each axis from the vectors' own points.  Rebuilt
        when the front changes (:meth:`offer` replaces :attr:`vectors`).
        """
        if self._table_of is self.vectors:
            return self._dead_table
        side = self.space.n_phases + 1
        table = None
        if side**self.space.n_groups <= _TABLE_ENTRIES:
            table = np.zeros((side,) * self.space.n_groups, dtype=bool)
            table[tuple(np.clip(self.vectors, 0, self.space.n_phases).T)] = True
            for axis in range(self.space.n_groups):
                table = np.logical_or.accumulate(table, axis=axis)
        self._table_of, self._dead_table = self.vectors, table
        return table

    def alive(self, masks: np.ndarray, cores: np.ndarray, kernels: np.ndarray | None = None) -> np.ndarray:
        """Whether the subtree of each flat may still hold a vector the front does not dominate or equal.

        Flats below a flat with core ``c`` agree with it on the slots
        ``<= c``, so the slots up to ``c`` it misses are missed by all of
        them: a lower bound on their ``z``.
        """
        decided = np.arange(self.space.size)[None, :] <= cores[:, None]
        ok = ~self.dead(self.misses(masks | ~decided))
        if (
            kernels is not None
            and kernels.shape[2] in (2, 3)
            and self.space.rows.shape[1] == 1
            and not np.iscomplexobj(self.space.rows)
            and self.vectors.shape[0] > 0
        ):
            rows = np.flatnonzero(ok)
            if rows.size:
                ok[rows] = self._alive_planes(masks[rows], ~decided[rows] & ~masks[rows], kernels[rows])
        return ok

    def _alive_planes(self, masks: np.ndarray, later: np.ndarray, kernels: np.ndarray) -> np.ndarray:
        """Flats with a two- or three-dimensional kernel ``K``: whether some set of later slots below may beat the front.

        Every flat below such a flat ``Q`` is ``Q`` plus later slots that
        vanish at one ``u`` in ``K``.  With ``dim K = 2`` their projections
        ``r K`` are parallel, so they lie in one chain of
        :func:`kfio.search._pareto_proof.parallel_chains` (with the short
        projections, counted in every class).  With ``dim K = 3`` they lie
        near one plane: projected orthogonally to their longest row (the
        pivot, :func:`kfio.search._pareto_proof.pivot_projections`, whose
        docstring gives the argument) they are parallel within ``3 tol``.  The
        subtree is cut
        when ``Q`` plus any chain and the short slots misses a vector the
        front dominates or equals.  First, a flat whose largest chain plus
        short slots holds fewer than ``need`` slots is cut at once
        (:func:`kfio.search._chains.longest_chain`, and per pivot rank
        :func:`kfio.search._chains.plane_candidates`): the same flats are
        cut, before any chain is labelled.
        """
        from ._chains import longest_chain, plane_candidates  # local: _chains imports _pareto_proof
        from ._pareto_proof import parallel_chains, pivot_projections  # local: _pareto_proof imports Front's protocol

        C = masks.shape[0]
        alive = np.zeros(C, dtype=bool)
        need = self.slots_to_escape(self.misses(masks))
        # A set below Q escapes the front only with at least ``need`` later slots.
        rows = np.flatnonzero(later.sum(axis=1) >= need)
        if rows.size == 0:
            return alive
        masks, later, kernels, need = masks[rows], later[rows], kernels[rows], need[rows]
        W = np.matmul(self.space.rows[None, :, 0, :], kernels)
        if kernels.shape[2] == 2:
            # A chain escapes only with ``need`` slots: the largest chain first (:mod:`kfio.search._chains`).
            best, short = longest_chain(W, later, self.space.tol)
            sub = np.flatnonzero(best + short >= need)
            if sub.size:
                alive[rows[sub]] = self._alive_chains(masks[sub], *parallel_chains(W[sub], later[sub], self.space.tol))
            return alive
        # Most flats no pivot can save: one projection per length rank over its members only.
        sub = np.flatnonzero(plane_candidates(W, later, need, 3 * self.space.tol))
        rows, masks, later, W, need = rows[sub], masks[sub], later[sub], W[sub], need[sub]
        for c, _, V, members in pivot_projections(W, later, need):
            best, short = longest_chain(V, members, 3 * self.space.tol)
            sub = np.flatnonzero(best + short >= need[c])
            if sub.size == 0:
                continue
            c = c[sub]
            live = self._alive_chains(masks[c], *parallel_chains(V[sub], members[sub], 3 * self.space.tol))
            alive[rows[c[live]]] = True
        return alive

    def slots_to_escape(self, z: np.ndarray) -> np.ndarray:
        """Per miss vector ``z``: the fewest slots a superset must add to miss a vector the front does not dominate or equal.

        Adding a slot of group ``g`` lowers ``z_g`` by one, so this is the
        distance in steps down the grid from ``z`` to the nearest point
        outside the dominated region (0 when ``z`` itself is outside), by
        relaxing ``D(z) = 1 + min_g D(z - e_g)`` over the table of
        :meth:`_table`; ``N0 G + 1`` (more than any set holds) when no point
        below ``z`` escapes.  Without a table, 0 (no bound).
        """
        table = self._table()
        if table is None:
            return np.zeros(z.shape[0], dtype=int)
        if self._escape_of is not self.vectors:
            G, big = self.space.n_groups, self.space.n_phases * self.space.n_groups + 1
            D = np.where(table, big, 0)
            while True:
                step = D.copy()
                for g in range(G):
                    lower = [slice(None)] * G
                    upper = [slice(None)] * G
                    lower[g], upper[g] = slice(None, -1), slice(1, None)
                    step[tuple(upper)] = np.minimum(step[tuple(upper)], D[tuple(lower)] + 1)
                step = np.minimum(step, big)
                if np.array_equal(step, D):
                    break
                D = step
            self._escape_of, self._escape = self.vectors, D
        side = self.space.n_phases + 1
        strides = side ** np.arange(self.space.n_groups - 1, -1, -1)
        return np.asarray(self._escape.ravel()[np.clip(z, 0, self.space.n_phases) @ strides])

    def _alive_chains(self, masks: np.ndarray, chain: np.ndarray, short: np.ndarray) -> np.ndarray:
        """Per flat: whether ``Q`` plus the short slots plus one chain's slots (some chain) escapes the front."""
        C, S = masks.shape
        G = self.space.n_groups
        base = self.misses(masks | short)
        # Slots per (flat, chain, group), one bincount: the chain's slots hold phases of their groups.
        c, t = np.nonzero(chain >= 0)
        ids = (c * S + chain[c, t]) * G + t % G
        per_chain = np.bincount(ids, minlength=C * S * G).reshape(C, S, G)
        used = np.asarray(per_chain.any(axis=2))
        used[:, 0] = True  # a flat whose later slots are all short still has its one class
        fc, k = np.nonzero(used)
        live = ~self.dead(base[fc] - per_chain[fc, k])
        return np.asarray(np.bincount(fc[live], minlength=C) > 0)

    def alive_hulls(self, hulls: np.ndarray) -> np.ndarray:
        """Whether a subtree whose flats all lie inside a row of ``hulls`` may beat the front.

        Every set inside a hull misses at least the slots the hull misses.
        """
        return ~self.dead(self.misses(hulls))

    def visit(self, masks: np.ndarray, kernels: np.ndarray) -> None:
        """The front needs only maximal sets."""

    def offer(self, masks: np.ndarray) -> None:
        """Add the maximal blind sets (rows) whose miss vectors are not dominated or equalled."""
        if masks.shape[0] == 0:
            return
        z = self.misses(masks)
        for i in np.flatnonzero(~self.dead(z)):
            zi = z[i]
            if self.dead(zi[None, :])[0]:
                continue  # an earlier row of this batch dominates or equals it
            keep = ~(self.vectors >= zi[None, :]).all(axis=1)
            self.vectors = np.concatenate([self.vectors[keep], zi[None, :]])
            self.masks = [m for m, k in zip(self.masks, keep) if k] + [masks[i].copy()]


def group_extremes(
    space: SlotSpace, budget: Budget, margins: Margins, exponents: Sequence[int] | None = None
) -> tuple[np.ndarray, list[np.ndarray]]:
    """``m_g``, the fewest slots of group ``g`` that a blind set misses, and a maximal blind set attaining each.

    A subset of a blind set is blind, so ``D`` blind gives ``D cap g`` blind
    for group ``g`` alone: ``z_g(D) >= N0 - (largest blind set of g alone)``,
    from the one-group branch and bound for the largest blind set (0 when
    group ``g`` alone is rank-deficient).  That largest set has rank
    ``L - 1``; the zero set of its kernel line over every group is a
    maximal blind set with ``z_g = m_g``, returned to seed the front.

    With the block's ``exponents`` and one row per slot, each one-group
    search stops at :func:`kfio.search._cyclic.largest_blind_bound` (a
    group of full rank alone has no zero ``c_j`` and distinct exponents),
    which gives the same set.
    """
    from ._cyclic import largest_blind_bound  # local: _cyclic imports search from _blind, as this module does

    enough = None
    if exponents is not None and space.rows.shape[1] == 1:
        bound = largest_blind_bound(space.n_phases, exponents, budget)
        enough = None if bound is None else float(bound)
    out = np.zeros(space.n_groups, dtype=int)
    seeds = []
    index = np.arange(space.size)
    for g in range(space.n_groups):
        sub = group_space(space, g)
        if sub.rank(np.ones(sub.size, dtype=bool), margins) < sub.n_columns:
            continue
        objective = Objective(score=_held, max_weight=functools.partial(_most_misses, sub.size), enough=enough)
        best = search(sub, budget, margins, objective).maximal[0]
        out[g] = space.n_phases - int(best.sum())
        held = np.isin(index, np.flatnonzero(best) * space.n_groups + g)
        _, sv, vh = np.linalg.svd(space.rows[held].reshape(-1, space.n_columns))
        if int((~margins.record(sv)).sum()) == space.n_columns - 1:
            v = vh[-1].conj()
            seeds.append(margins.record(np.linalg.norm(space.rows @ v, axis=1)))
    return out, seeds


def group_lower_bounds(space: SlotSpace, budget: Budget, margins: Margins) -> np.ndarray:
    """``m_g`` of :func:`group_extremes`."""
    return group_extremes(space, budget, margins)[0]


def _most_misses(size: int, best: float) -> int:
    """Most slots a set may miss and still hold more than ``best`` slots."""
    return size - int(best) - 1


def _held(masks: np.ndarray) -> np.ndarray:
    arr: np.ndarray = masks.sum(axis=1).astype(float)
    return arr


@dataclass(frozen=True)
class PartialFront:
    """What a Pareto search had established when its budget ran out.

    Attributes
    ----------
    masks:
        Maximal blind sets found (numerical ranks), one per undominated miss
        vector of the front so far; each is a lower bound on ``sigma``.
    lower:
        ``m_g`` of :func:`group_extremes` (every blind set misses at least
        ``m_g`` slots of group ``g``), or ``None`` when the one-group
        searches did not finish.
    """

    masks: tuple[np.ndarray, ...]
    lower: np.ndarray | None


class FrontBudgetExceeded(BudgetExceeded):
    """:class:`~kfio.errors.BudgetExceeded` of :func:`pareto_search`, with the front found so far."""

    def __init__(self, message: str, found: PartialFront) -> None:
        super().__init__(message)
        self.found = found


def pareto_search(
    space: SlotSpace, budget: Budget, margins: Margins, exponents: Sequence[int] | None = None
) -> SearchResult:
    """One maximal blind set per undominated miss vector (Rohr, Marelli and Fu (2014), Corollary 2).

    The batched closure walk of :func:`kfio.search._blind_batch.walk`
    (gap-canonical rotations, real rows where the plant is real) with
    :class:`Front` deciding which subtrees to keep.  With two groups the
    walk stops after :data:`PROBE_FLATS` flats (by default it does not
    start) and :func:`kfio.search._pareto_proof.prove_front` completes
    the front from the big flats of one group at a time (the walk over both
    groups grows like ``C(S, L - 1) / N0`` with dense sensor rows).

    ``exponents`` (the block's, optional) let the one-group searches for
    ``m_g`` stop early (:func:`group_extremes`).

    Returns
    -------
    SearchResult
        :attr:`~SearchResult.maximal` holds one representative per
        undominated vector ``z``, rotated to its orbit key, in the order of
        the keys.

    Raises
    ------
    FrontBudgetExceeded
        When ``budget`` runs out (one tick per expanded flat, also in the
        one-group searches for ``m_g``), with the sets and bounds found so far.
    """
    lower: np.ndarray | None = None
    front: Front | None = None
    try:
        lower, seeds = group_extremes(space, budget, margins, exponents)
        front = Front(space, lower)
        return _pareto_search(space, budget, margins, front, seeds)
    except BudgetExceeded as exc:
        masks = tuple(front.masks) if front is not None else ()
        raise FrontBudgetExceeded(str(exc), PartialFront(masks, lower)) from exc


def _pareto_search(
    space: SlotSpace, budget: Budget, margins: Margins, front: Front, seeds: list[np.ndarray]
) -> SearchResult:
    from ._blind_batch import NodeCap, real_space, walk  # local: _blind_batch is heavier and imports _blind too
    from ._pareto_proof import prove_front

    if seeds:
        front.offer(np.array(seeds))
    real = real_space(space)
    front.space = real  # the walk's kernels are in the real rows' coordinates (Front.alive projects onto them)
    cap = PROBE_FLATS if space.n_groups == 2 else None
    checked = None
    try:
        if cap == 0:
            raise NodeCap("no walk over both groups")
        nodes = walk(real, budget, margins, front, max_nodes=cap)
    except NodeCap:
        nodes = cap or 0
        checked = prove_front(real, front, budget, margins)
    keys = sorted(space.orbit_key(m) for m in front.masks)
    reps = tuple(np.isin(np.arange(space.size), key) for key in keys)
    return SearchResult(maximal=reps, nodes=nodes, planes=0, window=real.window(margins), checked=checked)
