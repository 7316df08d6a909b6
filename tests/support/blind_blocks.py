"""Blocks and oracles shared by the blind-set search tests: random phase blocks, the bench blocks, miss vectors.

``random_block`` makes small phase blocks with coincidences (blind sets are
large), ``bench_block`` the two-sensor blocks of ``bench/bench_sensors.py``
from the analysis pipeline, and ``subsets_front`` the undominated miss
vectors of every subset (the oracle of last resort).
"""

from __future__ import annotations

import itertools
import json
import math

import numpy as np

from kfio import load_request
from kfio._budget import Budget
from kfio.search._blind import Margins, SlotSpace
from kfio.search._blind_batch import enumerate_orbits
from kfio.sigma._sigma import undominated
from kfio.structure import fmo_blocks
from kfio.structure._phases import PhaseBlock

from support.plants import block_diagonal, cyclotomic_companion


def random_block(rng: np.random.Generator, N0: int, groups: int, rows: int, real: bool) -> PhaseBlock:
    """``groups`` row groups of ``rows`` rows over ``N0`` phases, exponents of small orders (degenerate often).

    ``real``: columns in conjugate pairs (a real plant); some blocks get a
    zero column entry or a repeated exponent, so that blind sets are large.
    """
    L = int(rng.integers(2, 7))
    p = groups * rows
    divisors = [m for m in range(1, N0 + 1) if N0 % m == 0]
    if real:
        exps: list[int] = []
        cols = []
        while len(exps) + 2 <= L:
            m = int(rng.choice(divisors))
            e = int(rng.integers(0, m)) * (N0 // m)
            col = rng.integers(-2, 3, size=p) + 1j * rng.integers(-2, 3, size=p)
            exps += [e, -e % N0]
            cols += [col, col.conj()]
        if len(exps) < L:
            exps.append(0)
            cols.append(rng.integers(-2, 3, size=p).astype(complex))
        c = np.array(cols).T
    else:
        exps = [int(rng.integers(0, m)) * (N0 // m) for m in rng.choice(divisors, size=L)]
        c = rng.integers(-2, 3, size=(p, L)) + 1j * rng.integers(-2, 3, size=(p, L))
    if not np.abs(c).sum(axis=0).all():
        c[0, np.abs(c).sum(axis=0) == 0] = 1
    c = c / np.linalg.norm(c, axis=0)
    row_groups = tuple(tuple(range(g * rows, (g + 1) * rows)) for g in range(groups))
    return PhaseBlock(N0, tuple(exps), c, row_groups)


def vectors(space: SlotSpace, masks) -> list[tuple[int, ...]]:
    return sorted(
        tuple(int(x) for x in space.n_phases - m.reshape(space.n_phases, space.n_groups).sum(axis=0)) for m in masks
    )


def rank(space: SlotSpace, mask: np.ndarray) -> int:
    M = space.rows[mask].reshape(-1, space.n_columns)
    return int(np.linalg.matrix_rank(M, tol=1e-8)) if M.shape[0] else 0


def assert_maximal_blind(space: SlotSpace, mask: np.ndarray) -> None:
    L = space.n_columns
    assert rank(space, mask) < L
    for t in np.flatnonzero(~mask):
        assert rank(space, mask | (np.arange(space.size) == t)) == L


def subsets_front(space: SlotSpace) -> list[tuple[int, ...]]:
    """Undominated miss vectors of all maximal rank-deficient subsets, from all ``2^S`` subsets."""
    S, L = space.size, space.n_columns
    blind = [
        sub
        for k in range(S + 1)
        for sub in itertools.combinations(range(S), k)
        if np.linalg.matrix_rank(space.rows[list(sub)].reshape(-1, L), tol=1e-8) < L
    ]
    sets = [set(b) for b in blind]
    maximal = [np.isin(np.arange(S), sorted(b)) for b in sets if not any(b < c for c in sets)]
    z = set(vectors(space, maximal))
    return sorted(a for a in z if not any(b != a and all(x <= y for x, y in zip(b, a)) for b in z))


def bench_block(factors: tuple[int, ...], dense: bool) -> PhaseBlock:
    """The blocks of ``bench/bench_sensors.py``: rows ``e_1, e_2`` or dense rows from ``random.Random(period)``."""
    import random

    A = block_diagonal(*[cyclotomic_companion(m) for m in factors])
    n, period = len(A), math.lcm(*factors)
    if dense:
        rng = random.Random(period)
        rows = [[rng.randint(-3, 3) for _ in range(n)] for _ in range(2)]
    else:
        rows = [[1] + [0] * (n - 1), [0, 1] + [0] * (n - 2)]
    body = {
        "system": {"A": A, "C": rows, "sensors": [{"name": "s0", "rows": [0]}, {"name": "s1", "rows": [1]}]},
        "channel": {
            "model": "per_sensor",
            "channels": {s: {"model": "bernoulli", "arrival_probability": "1/2"} for s in ("s0", "s1")},
        },
    }
    (block,) = [b for b in fmo_blocks(load_request(json.dumps(body)).system) if b.phase is not None]
    assert block.phase is not None
    return block.phase


def assert_front_matches_enumeration(space: SlotSpace, maximal) -> None:
    """``maximal`` holds maximal blind sets with exactly the undominated miss vectors of every shift orbit."""
    every = enumerate_orbits(space, Budget(max_steps=2_000_000), Margins(space.tol))
    assert vectors(space, maximal) == sorted(set(vectors(space, undominated(space, list(every.maximal)))))
    for m in maximal:
        assert_maximal_blind(space, m)
