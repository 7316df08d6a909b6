"""The batched enumeration of maximal blind orbits against the one-at-a-time walk and brute force."""

from __future__ import annotations

import itertools
import json
from fractions import Fraction

import numpy as np
import pytest

from kfio import load_request
from kfio._budget import Budget
from kfio.model._types import MarkovChannel
from kfio.search._blind import Margins, SlotSpace, search
from kfio.search._blind_batch import _gap_canonical_children, enumerate_orbits, gap_canonical_possible, real_space
from kfio.sigma._sigma import undominated
from kfio.stability import compute_sigma
from kfio.structure import fmo_blocks
from kfio.structure._phases import PhaseBlock

from support.plants import block_diagonal, cyclotomic_companion

SEED = 20261201


def random_block(rng: np.random.Generator, N0: int, real: bool, rows: int = 1) -> PhaseBlock:
    """Two row groups over ``N0`` phases; ``real``: columns in conjugate pairs, as a real plant gives."""
    L = int(rng.integers(2, 7))
    p = 2 * rows
    if real:
        pairs = rng.choice(np.arange(1, (N0 + 1) // 2), size=min(L // 2, (N0 - 1) // 2), replace=False)
        exps, cols = [], []
        for e in pairs:
            col = rng.integers(-2, 3, size=p) + 1j * rng.integers(-2, 3, size=p)
            exps += [int(e), int(-e % N0)]
            cols += [col, col.conj()]
        exps.append(0)
        cols.append(rng.integers(-2, 3, size=p).astype(complex))
        shift = int(rng.integers(0, N0))  # exponents relative to another member of the class
        exps = [(e + shift) % N0 for e in exps]
        c = np.array(cols).T
    else:
        exps = [int(e) for e in rng.integers(0, N0, size=L)]
        c = rng.integers(-2, 3, size=(p, L)) + 1j * rng.integers(-2, 3, size=(p, L))
    c = c / np.maximum(np.linalg.norm(c, axis=0), 1e-300)
    groups = (tuple(range(rows)), tuple(range(rows, p)))
    return PhaseBlock(N0, tuple(exps), c, groups)


def orbits(block: PhaseBlock, route: str) -> list[tuple[int, ...]]:
    space = SlotSpace.from_block(block)
    run = enumerate_orbits if route == "batched" else search
    res = run(space, Budget(max_steps=2_000_000), Margins(space.tol))
    return [tuple(int(i) for i in np.flatnonzero(m)) for m in res.maximal]


def orbit_keys_by_subsets(block: PhaseBlock) -> set[tuple[int, ...]]:
    """Orbit keys of every maximal rank-deficient subset, by trying all ``2^S`` subsets."""
    space = SlotSpace.from_block(block)
    S, L = space.size, space.n_columns
    rows = space.rows
    blind = []
    for k in range(S + 1):
        for sub in itertools.combinations(range(S), k):
            M = rows[list(sub)].reshape(-1, L)
            if np.linalg.matrix_rank(M, tol=1e-8) < L:
                blind.append(frozenset(sub))
    maximal = [F for F in blind if not any(F < G for G in blind)]
    return {space.orbit_key(np.isin(np.arange(S), sorted(F))) for F in maximal}


@pytest.mark.slow
@pytest.mark.parametrize("i", range(60))
def test_batched_orbits_equal_one_at_a_time(i: int) -> None:
    rng = np.random.default_rng([SEED, i])
    block = random_block(rng, N0=int(rng.integers(2, 13)), real=i % 3 != 0, rows=1 + (i % 5 == 4))
    assert orbits(block, "batched") == orbits(block, "flats")


@pytest.mark.parametrize("i", range(12))
def test_batched_orbits_equal_bruteforce(i: int) -> None:
    rng = np.random.default_rng([SEED, 500 + i])
    block = random_block(rng, N0=int(rng.integers(2, 7)), real=i % 2 == 0)
    assert set(orbits(block, "batched")) == orbit_keys_by_subsets(block)


@pytest.mark.parametrize("i", range(20))
def test_real_space_keeps_every_rank(i: int) -> None:
    rng = np.random.default_rng([SEED, 900 + i])
    block = random_block(rng, N0=int(rng.integers(3, 13)), real=True)
    space = SlotSpace.from_block(block)
    real = real_space(space)
    assert real.rows.dtype == np.float64, "conjugate pairs (after a unit scalar per phase) give real rows"
    for _ in range(30):
        mask = rng.random(space.size) < 0.4
        a = space.rows[mask].reshape(-1, space.n_columns)
        b = real.rows[mask].reshape(-1, space.n_columns)
        assert np.allclose(np.linalg.svd(a, compute_uv=False), np.linalg.svd(b, compute_uv=False), atol=1e-12)


def test_real_space_leaves_unpaired_rows_complex() -> None:
    block = PhaseBlock(5, (0, 1, 3), np.array([[1, 1j, 1], [1, 2, 1j]]) / np.sqrt(2), ((0,), (1,)))
    space = SlotSpace.from_block(block)
    assert real_space(space) is space


@pytest.mark.parametrize("N0", [3, 5, 6])
def test_every_orbit_has_a_gap_canonical_rotation(N0: int) -> None:
    # Each non-empty mask, as a complete set (core = last slot), is gap-canonical in some rotation.
    rng = np.random.default_rng([SEED, N0])
    space = SlotSpace.from_block(PhaseBlock(N0, (0,), np.ones((2, 1), complex), ((0,), (1,))))
    masks = rng.random((200, space.size)) < 0.5
    masks = masks[masks.any(axis=1)]
    core = np.full(N0, space.size - 1)
    for m in masks:
        rotations = np.array([space.rotate(m, k) for k in range(N0)])
        assert gap_canonical_possible(space, rotations, core).any()


@pytest.mark.parametrize("N0", [1, 2, 5, 12, 31])
def test_gap_canonical_children_equal_the_general_test(N0: int) -> None:
    """One group: the lookup version for ``Q + e`` and for a closure adding slots after ``e`` equals the scan."""
    rng = np.random.default_rng([SEED, 40 + N0])
    space = SlotSpace.from_block(PhaseBlock(N0, (0,), np.ones((1, 1), complex), ((0,),)))
    Q = rng.random((300, N0)) < rng.random((300, 1))
    b, e = np.nonzero(~Q)
    ok, gap = _gap_canonical_children(Q, b, e)
    grown = Q[b].copy()
    grown[np.arange(b.size), e] = True
    assert np.array_equal(ok, gap_canonical_possible(space, grown, e))
    closures = grown | ((rng.random(grown.shape) < 0.3) & (np.arange(N0)[None, :] > e[:, None]))
    last = N0 - 1 - np.argmax(closures[:, ::-1], axis=1)
    assert np.array_equal(ok & (gap <= N0 - last), gap_canonical_possible(space, closures, e))


def two_sensor_block(A: list[list[int]], rows: list[list[int]]) -> PhaseBlock:
    n = len(A)
    body = {
        "system": {"A": A, "C": rows, "sensors": [{"name": f"s{k}", "rows": [k]} for k in range(len(rows))]},
        "channel": {
            "model": "per_sensor",
            "channels": {f"s{k}": {"model": "bernoulli", "arrival_probability": "1/2"} for k in range(len(rows))},
        },
    }
    blocks = [b for b in fmo_blocks(load_request(json.dumps(body)).system) if b.phase is not None]
    assert n >= 1 and blocks
    return blocks[0].phase


def e_rows(n: int) -> list[list[int]]:
    return [[1] + [0] * (n - 1), [0, 1] + [0] * (n - 2)]


def check_maximal_and_complete(block: PhaseBlock, found: list[tuple[int, ...]], samples: int) -> None:
    """Sampled representatives are blind and maximal; random maximal blind sets all lie in found orbits.

    A random maximal blind set: add the slots in a random order, each one
    only if the set stays rank-deficient (a route independent of closures).
    """
    space = SlotSpace.from_block(block)
    L, S = space.n_columns, space.size
    rng = np.random.default_rng([SEED, S])

    def rank(mask: np.ndarray) -> int:
        return int(np.linalg.matrix_rank(space.rows[mask].reshape(-1, L), tol=1e-8))

    for key in found[:: max(1, len(found) // samples)]:
        mask = np.isin(np.arange(S), key)
        assert rank(mask) == L - 1
        for t in np.flatnonzero(~mask):
            assert rank(mask | (np.arange(S) == t)) == L
    keys = set(found)
    for _ in range(samples):
        mask = np.zeros(S, dtype=bool)
        for t in rng.permutation(S):
            mask[t] = True
            mask[t] = rank(mask) < L
        assert space.orbit_key(mask) in keys


@pytest.mark.slow
def test_period_15_two_sensors_equals_one_at_a_time() -> None:
    block = two_sensor_block(cyclotomic_companion(15), e_rows(8))
    found = orbits(block, "batched")
    assert found == orbits(block, "flats")
    check_maximal_and_complete(block, found, samples=30)


@pytest.mark.parametrize("factors", [(4, 9), (3, 4, 5)])
def test_periods_36_and_60_two_sensors(factors) -> None:
    A = block_diagonal(*[cyclotomic_companion(m) for m in factors])
    block = two_sensor_block(A, e_rows(len(A)))
    assert orbits(block, "batched") == orbits(block, "flats")


@pytest.mark.slow
def test_period_21_two_sensors() -> None:
    # The one-at-a-time walk needs minutes here (1.8M flats); check every orbit instead.
    block = two_sensor_block(cyclotomic_companion(21), e_rows(12))
    space = SlotSpace.from_block(block)
    res = enumerate_orbits(space, Budget(max_steps=2_000_000), Margins(space.tol))
    found = [space.orbit_key(m) for m in res.maximal]
    assert len(set(found)) == len(found) > 1000
    check_maximal_and_complete(block, sorted(found), samples=25)
    # compute_sigma keeps one set per undominated miss vector (Bernoulli sensors), certified.
    ch = MarkovChannel("bernoulli", 0, (Fraction(1, 2),))
    sig = compute_sigma(block, [ch, ch], Budget(max_steps=2_000_000))
    z = {tuple(21 - m.reshape(21, 2).sum(axis=0)) for m in undominated(space, list(res.maximal))}
    assert {tuple(21 - sum(1 for n, h in F if h == g) for g in range(2)) for F in sig.maximal_blind_sets} == z
    assert sig.certified, "the undominated sets are confirmed in exact arithmetic"


def test_undominated_keeps_exactly_the_minimal_miss_vectors() -> None:
    rng = np.random.default_rng([SEED, 77])
    space = SlotSpace.from_block(PhaseBlock(5, (0,), np.ones((2, 1), complex), ((0,), (1,))))
    masks = [m for m in rng.random((40, space.size)) < 0.5]
    kept = undominated(space, masks)
    z = [tuple(5 - m.reshape(5, 2).sum(axis=0)) for m in masks]
    minimal = {a for a in z if not any(b != a and b[0] <= a[0] and b[1] <= a[1] for b in z)}
    assert [tuple(5 - m.reshape(5, 2).sum(axis=0)) for m in kept] == [a for a in z if a in minimal]
