"""Subtree bounds of the Pareto search and of the big-flat walk, against the walks without them.

Three bounds cut subtrees (several sensors):

* :meth:`Front.dead` looks dominance up in a table of the grid of miss vectors;
* :meth:`Front.alive` cuts a flat with a two-dimensional kernel when no chain
  of parallel projections (:func:`parallel_chains`) can beat the front;
* the same with a three-dimensional kernel, from the chains of the rows
  projected orthogonally to each pivot (:func:`pivot_projections`).

The cuts ask first how many slots a set must add to escape the front
(:meth:`Front.slots_to_escape`).  Each must leave the answer unchanged: the same fronts and representative
sets as the walk without the bound, and as the enumeration of every orbit;
the pieces are checked against brute force on planted configurations.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import kfio.search._pareto as pareto
import kfio.search._pareto_proof as proof
from kfio._budget import Budget
from kfio.search._blind import Margins, SlotSpace
from kfio.search._pareto import Front, pareto_search

from support.blind_blocks import assert_front_matches_enumeration, random_block

SEED = 20261204


@pytest.mark.parametrize("groups", [2, 3])
def test_dead_table_equals_pairwise_dominance(groups: int, monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng([SEED, groups])
    N0 = 7
    space = SlotSpace(n_phases=N0, n_groups=groups, rows=np.zeros((N0 * groups, 1, 1)), tol=1e-9)
    for _ in range(20):
        front = Front(space, rng.integers(0, 3, size=groups))
        front.vectors = rng.integers(0, N0 + 1, size=(int(rng.integers(1, 6)), groups))
        z = rng.integers(-1, N0 + 2, size=(200, groups))
        b = np.maximum(z, front.lower[None, :])
        brute = [any(all(x >= y for x, y in zip(row, v)) for v in front.vectors) for row in b]
        assert front.dead(z).tolist() == brute
        monkeypatch.setattr(pareto, "_TABLE_ENTRIES", 0)
        fresh = Front(space, front.lower)
        fresh.vectors = front.vectors
        assert fresh.dead(z).tolist() == brute, "without the table (grid too large)"
        monkeypatch.undo()


@pytest.mark.parametrize("groups", [2, 3])
def test_slots_to_escape_is_the_grid_distance_to_the_undominated_region(groups: int) -> None:
    rng = np.random.default_rng([SEED, 10 + groups])
    N0 = 5
    space = SlotSpace(n_phases=N0, n_groups=groups, rows=np.zeros((N0 * groups, 1, 1)), tol=1e-9)
    grid = np.array(list(itertools.product(range(N0 + 1), repeat=groups)))
    for _ in range(10):
        front = Front(space, np.zeros(groups, dtype=int))
        front.vectors = rng.integers(0, N0 + 1, size=(int(rng.integers(1, 5)), groups))
        free = grid[~front.dead(grid)]
        got = front.slots_to_escape(grid)
        for z, d in zip(grid, got):
            below = free[(free <= z).all(axis=1)]
            want = int((z - below).sum(axis=1).min()) if below.size else N0 * groups + 1
            assert d == want


def test_parallel_chains_keep_every_planted_class_together() -> None:
    rng = np.random.default_rng([SEED, 1])
    tol = 1e-9
    for _ in range(30):
        classes = int(rng.integers(1, 5))
        dirs = rng.uniform(0, np.pi, size=classes)
        label = rng.integers(0, classes, size=12)
        length = rng.uniform(0.5, 3, size=12) * rng.choice([-1, 1], size=12)
        noise = rng.uniform(-0.4, 0.4, size=12) * tol / np.abs(length)
        angle = dirs[label] + noise
        W = (length[:, None] * np.stack([np.cos(angle), np.sin(angle)], axis=1))[None]
        rows = np.ones((1, 12), dtype=bool)
        chain, short = proof.parallel_chains(W, rows, tol)
        assert not short.any()
        for k in range(classes):
            assert len(set(chain[0, label == k].tolist())) <= 1, "a class of parallel rows lies in one chain"
        assert (chain[0] >= 0).all()


def test_a_planted_plane_is_one_chain_seen_from_its_longest_row() -> None:
    rng = np.random.default_rng([SEED, 2])
    tol = 1e-9
    for _ in range(30):
        n = 10
        normal = rng.normal(size=3)
        normal /= np.linalg.norm(normal)
        W = rng.normal(size=(n, 3))
        k = int(rng.integers(2, n + 1))
        W[:k] -= (W[:k] @ normal)[:, None] * normal[None, :]  # k rows on a plane, within tol
        W[:k] += rng.uniform(-0.9, 0.9, size=(k, 1)) * tol * normal[None, :]
        planted = np.zeros(n, dtype=bool)
        planted[:k] = True
        perm = rng.permutation(n)
        W, planted = W[perm], planted[perm]
        longest = int(np.flatnonzero(planted)[np.argmax(np.linalg.norm(W[planted], axis=1))])
        rows = np.ones((1, n), dtype=bool)
        seen = False
        for need in (None, np.array([k])):
            for _, pivots, V, members in proof.pivot_projections(W[None], rows, need):
                i = int(np.flatnonzero(pivots == longest)[0])
                chain, short = proof.parallel_chains(V[i : i + 1], members[i : i + 1], 3 * tol)
                assert members[i, planted].all(), "the planted rows are no longer than their longest"
                assert len(set(chain[0, planted & ~short[0]].tolist())) <= 1, "one chain holds the planted plane"
                seen = True
        assert seen, "the longest planted row is a pivot"


def _cases() -> list[SlotSpace]:
    out = []
    for i in range(24):
        rng = np.random.default_rng([SEED, 100 + i])
        out.append(SlotSpace.from_block(random_block(rng, int(rng.integers(4, 9)), 3, rows=1, real=True)))
    return out


def test_three_group_plane_cut_keeps_the_front_and_its_sets(monkeypatch: pytest.MonkeyPatch) -> None:
    cut = 0
    original = Front._alive_planes

    def counting(self: Front, masks: np.ndarray, later: np.ndarray, kernels: np.ndarray) -> np.ndarray:
        nonlocal cut
        ok = original(self, masks, later, kernels)
        cut += int((~ok).sum())
        return ok

    for space in _cases():
        monkeypatch.setattr(Front, "_alive_planes", counting)
        fast = pareto_search(space, Budget(max_steps=2_000_000), Margins(space.tol))
        monkeypatch.setattr(Front, "_alive_planes", lambda self, masks, later, kernels: np.ones(len(masks), bool))
        slow = pareto_search(space, Budget(max_steps=2_000_000), Margins(space.tol))
        monkeypatch.undo()
        assert [m.tolist() for m in fast.maximal] == [m.tolist() for m in slow.maximal]
        assert fast.nodes <= slow.nodes
        assert_front_matches_enumeration(space, fast.maximal)
    assert cut > 0, "the cases exercise the cut"
