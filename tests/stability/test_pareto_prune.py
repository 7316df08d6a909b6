"""Subtree bounds of the Pareto search and of the big-flat walk, against the walks without them.

Three bounds cut subtrees (issue 25, several sensors):

* :meth:`Front.dead` looks dominance up in a table of the grid of miss vectors;
* :meth:`Front.alive` cuts a flat with a two-dimensional kernel when no chain
  of parallel projections (:func:`parallel_chains`) can beat the front;
* the big-flat walk cuts a flat with a three-dimensional kernel when no plane
  holds enough later rows (:func:`_most_coplanar`).

Each must leave the answer unchanged: the same fronts and representative
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
from kfio.search._blind import Margins, SlotSpace, group_space
from kfio.search._blind_batch import real_space
from kfio.search._pareto import Front, pareto_search

from support.blind_blocks import assert_front_matches_enumeration, bench_block, random_block

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


def _coplanar_brute(W: np.ndarray, tol: float) -> int:
    """Most rows of ``W`` (``n x 3``) within ``tol`` of one plane through 0, over the planes of row pairs."""
    best = 1
    for a, b in itertools.combinations(range(W.shape[0]), 2):
        x = np.cross(W[a], W[b])
        if np.linalg.norm(x) < 1e-6:
            continue
        x /= np.linalg.norm(x)
        best = max(best, int((np.abs(W @ x) <= tol).sum()))
    return best


def test_most_coplanar_bounds_the_largest_planted_plane() -> None:
    rng = np.random.default_rng([SEED, 2])
    tol = 1e-9
    for _ in range(30):
        n = 10
        normal = rng.normal(size=3)
        normal /= np.linalg.norm(normal)
        W = rng.normal(size=(n, 3))
        k = int(rng.integers(2, n + 1))
        W[:k] -= (W[:k] @ normal)[:, None] * normal[None, :]  # k rows on a plane
        W[:k] += rng.uniform(-0.3, 0.3, size=(k, 1)) * tol * normal[None, :]
        W = W[rng.permutation(n)]
        true = _coplanar_brute(W, 2 * tol)
        assert true >= k
        rows = np.ones((1, n), dtype=bool)
        for need in (1, k - 1, k, k + 1):
            got = int(proof._most_coplanar(W[None], rows, tol, np.array([need]))[0])
            if true >= need:
                assert got >= need, "a plane holding need rows is never cut"


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


@pytest.mark.parametrize(("factors", "T"), [((15,), 3), ((15,), 6), ((21,), 14), ((4, 9), 20)])
def test_coplanar_cut_keeps_every_big_flat(factors: tuple[int, ...], T: int, monkeypatch: pytest.MonkeyPatch) -> None:
    space = real_space(SlotSpace.from_block(bench_block(factors, dense=True)))
    group = group_space(space, 0)
    cut = 0
    original = proof._most_coplanar

    def counting(W: np.ndarray, rows: np.ndarray, tol: float, need: np.ndarray) -> np.ndarray:
        nonlocal cut
        out = original(W, rows, tol, need)
        cut += int((out < need).sum())
        return out

    monkeypatch.setattr(proof, "_most_coplanar", counting)
    found, _ = proof.big_flats(group, T, Budget(max_steps=2_000_000), Margins(group.tol))
    monkeypatch.setattr(proof, "_most_coplanar", lambda W, rows, tol, need: np.full(W.shape[0], 10**6))
    every, _ = proof.big_flats(group, T, Budget(max_steps=2_000_000), Margins(group.tol))
    monkeypatch.undo()
    assert sorted(m.tobytes() for m, _ in found) == sorted(m.tobytes() for m, _ in every)
    assert all(int(m.sum()) >= T for m, _ in found)
    assert cut > 0 or factors == (15,), "the larger blocks exercise the cut"
