"""The Pareto search for undominated miss vectors against enumeration, all subsets and brute force.

Under independent Bernoulli sensors ``compute_sigma`` keeps one maximal blind
set per undominated miss vector (:mod:`kfio.search._pareto`).  Oracles:

* the enumeration of every shift orbit (:func:`enumerate_orbits`, the
  previous route) followed by :func:`undominated`;
* every subset of the slots of tiny blocks (no closures, no rotations);
* the covered-set dynamic programme of :mod:`bruteforce_sensors` on plants
  built from cyclotomic blocks (floating-point eigenvectors, no FMO code).
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from kfio import analyze
from kfio._budget import Budget
from kfio.errors import BudgetExceeded
from kfio.model._types import MarkovChannel
from kfio.search._blind import Margins, SlotSpace
from kfio.search._blind_batch import enumerate_orbits
from kfio.search._pareto import Front, group_lower_bounds, pareto_search
from kfio.sigma._sigma import undominated
from kfio.stability import compute_sigma
from kfio.structure._phases import PhaseBlock

from support.blind_blocks import (
    assert_front_matches_enumeration,
    bench_block,
    random_block,
    subsets_front,
    vectors,
)
from support.bruteforce_sensors import bernoulli, block_rates, sensor_request
from support.plants import block_diagonal, cyclotomic_companion

SEED = 20261202


def case(i: int) -> PhaseBlock:
    rng = np.random.default_rng([SEED, i])
    groups = 3 if i % 4 == 3 else 2
    N0 = int(rng.integers(2, 7 if groups == 3 else 13))
    return random_block(rng, N0, groups, rows=1 + (i % 5 == 4), real=i % 3 != 0)


@pytest.mark.parametrize("i", range(80))
def test_front_equals_undominated_orbits(i: int) -> None:
    block = case(i)
    space = SlotSpace.from_block(block)
    front = pareto_search(space, Budget(max_steps=2_000_000), Margins(space.tol))
    assert_front_matches_enumeration(space, front.maximal)
    for m in front.maximal:
        assert tuple(np.flatnonzero(m)) == space.orbit_key(m), "representatives are rotated to their orbit key"


@pytest.mark.parametrize("i", range(40))
def test_front_equals_all_subsets(i: int) -> None:
    rng = np.random.default_rng([SEED, 3000 + i])
    groups = 3 if i % 3 == 2 else 2
    N0 = int(rng.integers(2, 4 if groups == 3 else 6))
    block = random_block(rng, N0, groups, rows=1, real=i % 2 == 0)
    space = SlotSpace.from_block(block)
    front = pareto_search(space, Budget(max_steps=100_000), Margins(space.tol))
    assert vectors(space, front.maximal) == subsets_front(space)


def test_unobserved_group_and_unobserved_column() -> None:
    # Group 1 has a zero row: it is in every closure, m_1 = 0 and every vector has z_1 = 0.
    block = PhaseBlock(4, (0, 1, 3), np.array([[1, 1, 1], [0, 0, 0]], dtype=complex), ((0,), (1,)))
    space = SlotSpace.from_block(block)
    lower = group_lower_bounds(space, Budget(max_steps=10_000), Margins(space.tol))
    expected = subsets_front(space)
    assert lower[1] == 0 and all(z[1] == 0 and z[0] >= lower[0] for z in expected)
    front = pareto_search(space, Budget(max_steps=10_000), Margins(space.tol))
    assert vectors(space, front.maximal) == expected
    # A column nobody sees: every set is blind, the one vector is z = 0.
    dead = PhaseBlock(3, (0, 1), np.array([[1, 0], [1, 0]], dtype=complex), ((0,), (1,)))
    space = SlotSpace.from_block(dead)
    assert vectors(space, pareto_search(space, Budget(max_steps=1000), Margins(space.tol)).maximal) == [(0, 0)]


def test_front_keeps_only_undominated_vectors() -> None:
    space = SlotSpace.from_block(PhaseBlock(4, (0,), np.ones((2, 1), complex), ((0,), (1,))))
    front = Front(space, np.array([0, 1]))
    rng = np.random.default_rng([SEED, 5])
    masks = rng.random((60, space.size)) < 0.5
    masks[:, 1] = False  # slot (0, 1) is never held: z_1 >= 1, as the lower bound promises
    for part in np.array_split(masks, 7):
        front.offer(part)
    z = vectors(space, masks)
    minimal = sorted({a for a in z if not any(b != a and all(x <= y for x, y in zip(b, a)) for b in z)})
    assert sorted(map(tuple, front.vectors.tolist())) == minimal
    assert vectors(space, front.masks) == minimal


def plant_case(i: int) -> tuple[list[list[int]], list[list[list[int]]], list[float]]:
    """Cyclotomic blocks of small period, random integer sensor rows (2 or 3 sensors)."""
    rng = np.random.default_rng([SEED, 7000 + i])
    sensors = 3 if i % 4 == 3 else 2
    choices = (
        [(3,), (4,), (6,), (5,), (2, 3), (2, 4), (3, 6), (4, 2, 2)] if sensors == 2 else [(3,), (4,), (2, 2), (2, 4)]
    )
    factors = choices[int(rng.integers(0, len(choices)))]
    A = block_diagonal(*[cyclotomic_companion(int(m), alpha=int(rng.choice([2, 3]))) for m in factors])
    n = len(A)
    while True:
        Cs = [[[int(x) for x in rng.integers(-1, 2, size=n)]] for _ in range(sensors)]
        C = np.array([rows[0] for rows in Cs], dtype=float)
        obs = np.vstack([C @ np.linalg.matrix_power(np.array(A, dtype=float), k) for k in range(n)])
        if np.linalg.matrix_rank(obs) == n:
            break  # an unobservable mode keeps every pattern blind: the oracle's DP would visit 2^S sets
    lambdas = [float(x) for x in rng.choice([0.3, 0.5, 0.7, 0.9], size=sensors)]
    return A, Cs, lambdas


@pytest.mark.slow
@pytest.mark.parametrize("i", range(24))
def test_block_rates_of_cyclotomic_plants_match_bruteforce(i: int) -> None:
    A, Cs, lambdas = plant_case(i)
    rep = analyze(sensor_request(A, Cs, lambdas, noise=False))
    mine = sorted((round(b.modulus**2, 9), b.rate) for b in rep.blocks if b.rate is not None)
    C = np.array([row for rows in Cs for row in rows], dtype=float)
    groups = [[s] for s in range(len(Cs))]
    oracle = sorted(
        (round(beta, 9), rate)
        for beta, rate in block_rates(np.array(A, float), C, groups, [bernoulli(x) for x in lambdas])
    )
    assert [b for b, _ in mine] == [b for b, _ in oracle]
    for (_, r1), (_, r2) in zip(mine, oracle):
        assert r1 == pytest.approx(r2, rel=1e-8)
    assert all(b.certified for b in rep.blocks)


@pytest.mark.parametrize("dense", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_period_15_bench_cases_equal_enumeration(dense: bool) -> None:
    block = bench_block((15,), dense)
    space = SlotSpace.from_block(block)
    every = enumerate_orbits(space, Budget(max_steps=2_000_000), Margins(space.tol))
    ch = MarkovChannel("bernoulli", 0, (Fraction(1, 2),))
    res = compute_sigma(block, [ch, ch], Budget(max_steps=2_000_000))
    assert vectors(space, [space.mask(sorted({(n % 15, g) for n, g in F})) for F in res.maximal_blind_sets]) == sorted(
        set(vectors(space, undominated(space, list(every.maximal))))
    )
    z = [15 - m.reshape(15, 2).sum(axis=0) for m in every.maximal]
    best = max(z, key=lambda v: -(v[0] + v[1]))
    assert sum(res.bernoulli_exponents) == Fraction(int(best.sum()), 15), "sigma = (1/2)^(total misses / N)"
    assert res.certified


def test_small_budget_stops_the_search() -> None:
    block = bench_block((21,), dense=False)
    ch = MarkovChannel("bernoulli", 0, (Fraction(1, 2),))
    with pytest.raises(BudgetExceeded):
        compute_sigma(block, [ch, ch], Budget(max_steps=40))
    with pytest.raises(BudgetExceeded):
        compute_sigma(bench_block((21,), dense=True), [ch, ch], Budget(seconds=0.2))
