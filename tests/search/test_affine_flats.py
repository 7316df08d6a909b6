"""One sensor's big flats once per affine orbit (``n -> a n + b``), against the rotation walk and brute force.

:mod:`kfio.search._affine` finds the unit multiples that preserve one
sensor's matroid, cuts the closure walk to flats that may be lex-first in
their affine orbit, and unrolls each into its shift orbits.  Checked here:

* every unit it reports preserves the rank of random phase sets, and the
  cyclotomic blocks of the bench report every unit;
* the lex-first tests cut nothing that some superset could still make
  lex-first (brute force over every superset, small periods);
* the big flats it lists are those of the rotation walk, orbit for orbit,
  and the two-sensor fronts are those without it.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import kfio.search._pareto as pareto
import kfio.search._pareto_proof as proof
from kfio._budget import Budget
from kfio.search._affine import Affine, unit_symmetries
from kfio.search._blind import Margins, SlotSpace, group_space
from kfio.search._blind_batch import real_space

from support.blind_blocks import bench_block, random_block, vectors

SEED = 20261203

CYCLOTOMIC = [((15,), True), ((21,), True), ((3, 4), True), ((4, 5), True), ((3, 7), True), ((4, 9), True)]


def one_group(factors: tuple[int, ...], dense: bool, real: bool = True) -> SlotSpace:
    space = group_space(SlotSpace.from_block(bench_block(factors, dense=dense)), 0)
    return real_space(space) if real else space


@pytest.mark.parametrize(("factors", "dense", "real"), [(f, d, i % 2 == 0) for i, (f, d) in enumerate(CYCLOTOMIC)])
def test_units_preserve_every_rank(factors: tuple[int, ...], dense: bool, real: bool) -> None:
    space = one_group(factors, dense, real)
    N0, rows = space.n_phases, space.rows[:, 0, :]
    units = unit_symmetries(space)
    assert units[0] == 1 and len(set(units)) == len(units)
    assert all(math.gcd(a, N0) == 1 for a in units)
    rng = np.random.default_rng([SEED, N0])
    L = space.n_columns
    for a in units:
        same = True
        for _ in range(60):
            F = rng.choice(N0, size=int(rng.integers(1, L + 1)), replace=False)
            r = np.linalg.matrix_rank(rows[F], tol=1e-8)
            if r != np.linalg.matrix_rank(rows[(a * F) % N0], tol=1e-8):
                same = False
                break
        assert same, a
    # Dense rows on cyclotomic blocks: every unit maps the exponents onto themselves.
    assert len(units) == sum(math.gcd(a, N0) == 1 for a in range(N0))


def test_random_exponents_have_only_the_reflection() -> None:
    """Random exponents: only ``n -> -n`` (``r_{-n}`` is the conjugate of ``r_n`` up to a column scaling)."""
    rng = np.random.default_rng([SEED, 1])
    space = group_space(SlotSpace.from_block(random_block(rng, 9, 2, rows=1, real=False)), 0)
    assert set(unit_symmetries(space)) <= {1, 8}
    rows = space.rows[:, 0, :]
    for a in unit_symmetries(space):
        for _ in range(50):
            F = rng.choice(9, size=int(rng.integers(1, space.n_columns + 1)), replace=False)
            assert np.linalg.matrix_rank(rows[F], tol=1e-8) == np.linalg.matrix_rank(rows[(a * F) % 9], tol=1e-8)


def lex_first(mask: np.ndarray, affine: Affine) -> bool:
    """Brute force: no image ``g(mask)`` holds an earlier first differing phase."""
    N0 = mask.size
    mine = tuple(np.flatnonzero(mask))
    for a in affine.units:
        for b in range(N0):
            image = tuple(sorted((a * (n - b)) % N0 for n in mine))
            if image < mine:
                return False
    return True


@pytest.mark.parametrize("units", [(1,), (1, 3, 5, 7), (1, 7)])
def test_lex_first_tests_cut_only_subtrees_without_a_lex_first_set(units: tuple[int, ...]) -> None:
    """Period 8: every ``(Q, core)`` cut has no superset agreeing with ``Q`` up to the core that is lex-first."""
    N0 = 8
    affine = Affine(N0, units)
    rng = np.random.default_rng([SEED, len(units)])
    first = {bits: lex_first(np.array(bits, dtype=bool), affine) for bits in itertools.product([0, 1], repeat=N0)}
    cut = 0
    for _ in range(400):
        Q = rng.random(N0) < 0.35
        c = int(rng.integers(-1, N0))
        free = [n for n in range(c + 1, N0) if not Q[n]]
        below = []
        for r in range(len(free) + 1):
            for extra in itertools.combinations(free, r):
                D = Q.copy()
                D[list(extra)] = True
                below.append(first[tuple(int(x) for x in D)])
        possible = bool(affine.lex_first_possible(Q[None, :], np.array([c]))[0])
        cut += not possible
        assert possible or not any(below), (Q, c)
        # The pair test: Q' = Q minus its phases after the core, plus e = core (a child before its closure).
        if c >= 0 and not Q[c]:
            P = Q.copy()
            ok = bool(affine.pairs_possible(P[None, :], np.array([0]), np.array([c]))[0])
            grown = P.copy()
            grown[c] = True
            free = [n for n in range(c + 1, N0) if not grown[n]]
            any_first = False
            for r in range(len(free) + 1):
                for extra in itertools.combinations(free, r):
                    D = grown.copy()
                    D[list(extra)] = True
                    any_first |= first[tuple(int(x) for x in D)]
            assert ok or not any_first, (P, c)
    assert cut > 50  # the tests do cut


@pytest.mark.parametrize(("factors", "dense"), CYCLOTOMIC)
def test_affine_big_flats_are_those_of_the_rotation_walk(factors: tuple[int, ...], dense: bool) -> None:
    space = one_group(factors, dense)
    affine = Affine(space.n_phases, unit_symmetries(space))
    assert not affine.trivial
    margins = Margins(space.tol)
    every, _ = proof.big_flats(space, 0, Budget(max_steps=10_000_000), margins)
    sizes = sorted({int(m.sum()) for m, _ in every})
    for T in [0, *sizes[len(sizes) // 3 :: 3]]:
        plain = {space.orbit_key(m) for m, _ in every if m.sum() >= T}
        found, _ = proof.big_flats(space, T, Budget(max_steps=10_000_000), margins, None, affine)
        keys = [space.orbit_key(m) for m, _ in found]
        assert len(keys) == len(set(keys)), "one flat per shift orbit"
        assert set(keys) == plain, T
        for m, K in found:
            if K is not None:
                assert np.linalg.norm(space.rows[m].reshape(-1, space.n_columns) @ K) <= 1e-8


@pytest.mark.parametrize(("factors", "dense"), [((15,), True), ((4, 5), True), ((4, 9), True)])
def test_two_sensor_front_is_that_without_the_affine_walk(
    factors: tuple[int, ...], dense: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The same undominated vectors (the sets representing them may differ: hits come in another order)."""
    monkeypatch.setattr(pareto, "PROBE_FLATS", 0)
    space = SlotSpace.from_block(bench_block(factors, dense=dense))
    monkeypatch.setattr(proof, "AFFINE", True)
    fast = pareto.pareto_search(space, Budget(max_steps=10_000_000), Margins(space.tol))
    monkeypatch.setattr(proof, "AFFINE", False)
    slow = pareto.pareto_search(space, Budget(max_steps=10_000_000), Margins(space.tol))
    assert vectors(space, fast.maximal) == vectors(space, slow.maximal)


@pytest.mark.parametrize("N0", [7, 42, 84, 100])
def test_rotation_keys_are_equal_exactly_on_shift_orbits(N0: int) -> None:
    """Against the sorted-tuple orbit key, on random masks and rotations of them (one and several 42-bit words)."""
    from kfio.search._affine import _rotation_keys

    rng = np.random.default_rng([SEED, N0])
    base = rng.random((12, N0)) < 0.4
    masks = np.concatenate([base, np.roll(base, 5, axis=1), np.roll(base[:, ::-1], 3, axis=1)])
    space = SlotSpace(n_phases=N0, n_groups=1, rows=np.zeros((N0, 1, 1)), tol=1e-9)
    keys = _rotation_keys(masks)
    ref = [space.orbit_key_reference(m) for m in masks]
    for i, j in itertools.combinations(range(len(masks)), 2):
        assert (keys[i] == keys[j]) == (ref[i] == ref[j]), (i, j)
