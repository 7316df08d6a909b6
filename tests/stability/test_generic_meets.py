"""Generic meets cut the Pareto walk of three or more sensors (issue 25, seventh pass).

:func:`generic_meets` builds blind sets from the largest flat of each rank of
each group alone (ranks summing to at most ``L - 1`` always share a kernel
vector); :meth:`Front.bound_by` cuts what their miss vectors dominate
strictly, without letting them into the answer.  Checked against brute force
(the cut region and the escape distance on the grid, the largest flat of each
rank from every subset), and end to end: the fronts and representative sets
with the seeds equal those without them and the enumeration of every orbit.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import kfio.search._pareto as pareto
from kfio._budget import Budget
from kfio.search._blind import Margins, SlotSpace, group_space
from kfio.search._blind_batch import real_space
from kfio.search._pareto import Front, generic_meets, pareto_search

from support.blind_blocks import assert_front_matches_enumeration, assert_maximal_blind, random_block, rank

SEED = 20261203


def _sets_with(space: SlotSpace, z: np.ndarray) -> np.ndarray:
    """Masks missing exactly ``z_g`` phases of each group ``g`` (rows of ``z``)."""
    N0, G = space.n_phases, space.n_groups
    masks = np.zeros((z.shape[0], N0, G), dtype=bool)
    for i, row in enumerate(z):
        for g in range(G):
            masks[i, : N0 - row[g], g] = True
    return masks.reshape(z.shape[0], -1)


@pytest.mark.parametrize("groups", [2, 3])
def test_bound_by_cuts_what_the_sets_dominate_strictly(groups: int, monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng([SEED, groups])
    N0 = 6
    space = SlotSpace(n_phases=N0, n_groups=groups, rows=np.zeros((N0 * groups, 1, 1)), tol=1e-9)
    grid = np.array(list(itertools.product(range(-1, N0 + 1), repeat=groups)))  # misses lie in [0, N0]
    for trial in range(30):
        front = Front(space, rng.integers(0, 2, size=groups))
        front.vectors = rng.integers(0, N0 + 1, size=(int(rng.integers(0, 4)), groups))
        seeds = rng.integers(0, N0 + 1, size=(int(rng.integers(1, 5)), groups))
        front.bound_by(_sets_with(space, seeds))
        b = np.maximum(grid, front.lower[None, :])
        brute = [
            any((row >= v).all() for v in front.vectors) or any((row >= s).all() and (row != s).any() for s in seeds)
            for row in b
        ]
        assert front.dead(grid).tolist() == brute
        monkeypatch.setattr(pareto, "_TABLE_ENTRIES", 0)
        fresh = Front(space, front.lower)
        fresh.vectors = front.vectors
        fresh.bound_by(_sets_with(space, seeds))
        assert fresh.dead(grid).tolist() == brute, "without the table (grid too large)"
        monkeypatch.undo()
        if trial % 3 == 0:
            # The escape distance is that of the table (no one-group bounds ``lower``).
            fresh = Front(space, np.zeros(groups, dtype=int))
            fresh.vectors = front.vectors
            fresh.bound_by(_sets_with(space, seeds))
            inside = np.clip(grid, 0, N0)
            free = inside[~fresh.dead(inside)]
            for z, d in zip(inside, fresh.slots_to_escape(inside)):
                below = free[(free <= z).all(axis=1)]
                assert d == (int((z - below).sum(axis=1).min()) if below.size else N0 * groups + 1)


def test_offer_keeps_a_set_that_attains_a_seed_and_drops_what_one_dominates() -> None:
    N0, G = 5, 3
    space = SlotSpace(n_phases=N0, n_groups=G, rows=np.zeros((N0 * G, 1, 1)), tol=1e-9)
    front = Front(space, np.zeros(G, dtype=int))
    front.bound_by(_sets_with(space, np.array([[2, 2, 2]])))
    front.offer(_sets_with(space, np.array([[2, 3, 2]])))
    assert front.vectors.shape[0] == 0, "strictly dominated by a seed: not in the answer"
    front.offer(_sets_with(space, np.array([[2, 2, 2], [1, 4, 4]])))
    assert sorted(map(tuple, front.vectors.tolist())) == [(1, 4, 4), (2, 2, 2)]


def _flats_by_rank(space: SlotSpace) -> dict[int, int]:
    """Largest flat of each rank of a one-group space, from the closure of every subset."""
    S, L = space.size, space.n_columns
    best: dict[int, int] = {}
    for k in range(S + 1):
        for sub in itertools.combinations(range(S), k):
            mask = np.isin(np.arange(S), sub)
            r = rank(space, mask)
            if r == L:
                continue
            closed = [t for t in range(S) if rank(space, mask | (np.arange(S) == t)) == r]
            best[r] = max(best.get(r, 0), len(closed))
    return best


def test_largest_flat_of_each_rank_equals_brute_force() -> None:
    seen = 0
    for i in range(16):
        rng = np.random.default_rng([SEED, 50 + i])
        block = random_block(rng, int(rng.integers(4, 9)), 1, rows=1, real=True)
        space = group_space(real_space(SlotSpace.from_block(block)), 0)
        found = pareto._largest_by_rank(space, Budget(), Margins(space.tol))
        want = _flats_by_rank(space)
        assert {r: int(m.sum()) for r, m in found.items()} == want
        for r, m in found.items():
            assert rank(space, m) == r
        seen += len(want) > 2
    assert seen > 0, "the cases have flats of several ranks"


def _cases(groups: int, count: int) -> list[SlotSpace]:
    out = []
    for i in range(count):
        rng = np.random.default_rng([SEED, 100 * groups + i])
        out.append(SlotSpace.from_block(random_block(rng, int(rng.integers(4, 9)), groups, rows=1, real=True)))
    return out


def test_generic_meets_are_maximal_blind_sets_the_front_dominates() -> None:
    for space in _cases(3, 12):
        real = real_space(space)
        seeds = generic_meets(real, Budget(), Margins(space.tol))
        slow = pareto_search(space, Budget(max_steps=2_000_000), Margins(space.tol))
        front = Front(real, np.zeros(3, dtype=int))
        final = front.misses(np.array(slow.maximal))
        for m, z in zip(seeds, front.misses(seeds)):
            assert_maximal_blind(real, m)
            assert (z[None, :] >= final).all(axis=1).any(), "a real blind set: the front dominates or equals it"


@pytest.mark.parametrize("groups", [3, 4])
def test_seeded_walk_keeps_the_front_and_its_sets(groups: int, monkeypatch: pytest.MonkeyPatch) -> None:
    fewer = 0
    for space in _cases(groups, 24 if groups == 3 else 8):
        monkeypatch.setattr(pareto, "SEED_MEETS", True)
        fast = pareto_search(space, Budget(max_steps=2_000_000), Margins(space.tol))
        monkeypatch.setattr(pareto, "SEED_MEETS", False)
        slow = pareto_search(space, Budget(max_steps=2_000_000), Margins(space.tol))
        monkeypatch.undo()
        assert [m.tolist() for m in fast.maximal] == [m.tolist() for m in slow.maximal]
        assert fast.nodes <= slow.nodes
        fewer += fast.nodes < slow.nodes
        assert_front_matches_enumeration(space, fast.maximal)
    assert fewer > 0, "the seeds cut some walk"
