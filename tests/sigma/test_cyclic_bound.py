"""The cyclic-code bound on the largest blind set of one row, and the search that stops at it.

Oracles: the full branch and bound (no bound), all subsets of tiny blocks,
and the product-code closed form ``N0 - 2^k`` for the primitive roots of
unity of a square-free ``N0`` with ``k`` prime factors.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from fractions import Fraction

import numpy as np
import pytest

from kfio._budget import Budget
from kfio.model._types import MarkovChannel
from kfio.search import Margins, SlotSpace, largest_blind_bound, search
from kfio.sigma import compute_sigma
from kfio.sigma._sigma import _objective
from kfio.structure._phases import PhaseBlock

SEED = 20261203
COMPOSITE = [6, 10, 12, 14, 15, 18, 20, 21, 24, 28, 30]


def one_row_block(rng: np.random.Generator, N0: int, L: int, exponents=None) -> PhaseBlock:
    exps = exponents if exponents is not None else sorted(rng.choice(N0, size=L, replace=False).tolist())
    c = rng.integers(1, 4, size=(1, len(exps))) * np.exp(2j * np.pi * rng.random((1, len(exps))))
    return PhaseBlock(N0, tuple(int(e) for e in exps), c / np.abs(c), ((0,),))


def largest(space: SlotSpace, enough: float | None = None):
    objective = _objective([MarkovChannel("bernoulli", 0, (Fraction(1, 2),), {})], space.n_phases, space.n_phases)
    return search(space, Budget(max_steps=500_000), Margins(space.tol), dataclasses.replace(objective, enough=enough))


@pytest.mark.parametrize("N0", [6, 10, 12, 15, 21, 30, 35, 42])
def test_primitive_roots_meet_the_product_code_closed_form(N0: int) -> None:
    units = [e for e in range(N0) if math.gcd(e, N0) == 1]
    k = sum(1 for p in range(2, N0 + 1) if N0 % p == 0 and all(p % q for q in range(2, p)))
    bound = largest_blind_bound(N0, units, Budget(max_steps=10_000))
    assert bound == N0 - 2**k
    space = SlotSpace.from_block(one_row_block(np.random.default_rng([SEED, N0]), N0, len(units), units))
    assert int(largest(space).maximal[0].sum()) == bound, "the bound is attained: a tensor of two-point differences"


@pytest.mark.parametrize("i", range(40))
def test_bound_holds_and_the_stopped_search_returns_the_same_set(i: int) -> None:
    rng = np.random.default_rng([SEED, i])
    N0 = int(rng.choice(COMPOSITE))
    if i % 2:  # a union of residue classes (often a product set, where the bound is tight)
        q = [m for m in range(2, N0) if N0 % m == 0 and math.gcd(m, N0 // m) == 1]
        m = int(rng.choice(q)) if q else N0
        keep = rng.random(m) < 0.6
        exps = [e for e in range(N0) if keep[e % m]] or [0]
    else:
        exps = None
    block = one_row_block(rng, N0, int(rng.integers(2, min(N0, 9))), exps)
    space = SlotSpace.from_block(block)
    bound = largest_blind_bound(N0, block.exponents, Budget(max_steps=10_000))
    full = largest(space)
    assert bound is not None and int(full.maximal[0].sum()) <= bound
    fast = largest(space, float(bound))
    assert np.array_equal(fast.maximal[0], full.maximal[0])
    assert fast.stopped == (int(full.maximal[0].sum()) == bound)
    if fast.stopped:
        assert fast.nodes <= full.nodes


@pytest.mark.parametrize("i", range(12))
def test_bound_against_all_subsets(i: int) -> None:
    rng = np.random.default_rng([SEED, 100 + i])
    N0 = int(rng.choice([6, 10, 12]))
    block = one_row_block(rng, N0, int(rng.integers(2, 6)))
    rows = np.array([block.rows(n)[0] for n in range(N0)])
    biggest = max(
        len(F)
        for r in range(N0 + 1)
        for F in itertools.combinations(range(N0), r)
        if np.linalg.matrix_rank(rows[list(F)], tol=1e-9) < block.n_columns
    )
    assert biggest <= largest_blind_bound(N0, block.exponents, Budget(max_steps=10_000))


def test_compute_sigma_notes_the_stop_and_keeps_the_set() -> None:
    units = [e for e in range(30) if math.gcd(e, 30) == 1]
    block = one_row_block(np.random.default_rng(SEED), 30, len(units), units)
    ch = MarkovChannel("bernoulli", 0, (Fraction(1, 3),), {})
    res = compute_sigma(block, [ch], Budget(max_steps=100_000))
    assert "stopped at the cyclic-code bound (no blind set holds more than 22 phases)" in res.notes[0]
    space = SlotSpace.from_block(block)
    assert frozenset(space.slots(largest(space).maximal[0])) == res.worst_blind_set
    assert res.bernoulli_exponents == (Fraction(8, 30),)
