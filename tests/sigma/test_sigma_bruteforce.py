"""``compute_sigma`` against the independent brute force of :mod:`bruteforce`.

Random degenerate blocks (built directly as :class:`PhaseBlock`) under random
Bernoulli, Gilbert-Elliott and order-2 Markov channels, one packet and two
packets.  Tolerance: ``|sigma - oracle| <= 1e-6``; the oracle's ratio over
``2^20`` periods converges far below that (docs/theory.md, "Checks").
"""

from __future__ import annotations

import itertools
from fractions import Fraction

import numpy as np
import pytest

from kfio.model._types import MarkovChannel
from kfio.sigma._sigma import compute_sigma
from kfio.structure._phases import PhaseBlock

from support.bruteforce import BlindDP, oracle_sigma

SEED = 20240611
TOL = 1e-6


def random_channel(rng: np.random.Generator, order: int) -> MarkovChannel:
    """Order 0, 1 or 2 with every probability in ``(0.05, 0.95)`` (Rohr, Marelli and Fu (2014), Assumption 1)."""
    table = tuple(Fraction(int(x), 100) for x in rng.integers(6, 95, size=1 << order))
    model = {0: "bernoulli", 1: "gilbert_elliott", 2: "markov"}[order]
    return MarkovChannel(model, order, table)


def structured_exponents(rng: np.random.Generator, N0: int, L: int) -> tuple[int, ...]:
    """Exponents ``k N0 / m`` for random divisors ``m`` of ``N0``.

    Roots of unity of small order make chains share phase structure (large
    blind sets, Example 1 of Rohr, Marelli and Fu (2014)); repeats are chains of one eigenvalue.
    """
    divisors = [m for m in range(1, N0 + 1) if N0 % m == 0]
    orders = rng.choice(divisors, size=L)
    return tuple(int(rng.integers(0, m)) * (N0 // int(m)) for m in orders)


def random_degenerate_block(rng: np.random.Generator, n_rows: int, groups: int = 1) -> PhaseBlock:
    """``N0`` in ``2..8``, 2-4 columns, small integer ``C_hat`` whose phase-0 rows lack full column rank.

    Blocks that no pattern observes (fully blind) are redrawn: they have their
    own tests and would make the comparison trivial.
    """
    p = n_rows * groups
    row_groups = tuple(tuple(range(g * n_rows, (g + 1) * n_rows)) for g in range(groups))
    while True:
        N0 = int(rng.integers(2, 9)) if groups == 1 else int(rng.integers(2, 5))
        L = int(rng.integers(2, 5))
        c = rng.integers(-2, 3, size=(p, L)).astype(complex)
        exponents = structured_exponents(rng, N0, L)
        block = PhaseBlock(N0, exponents, c / np.maximum(np.linalg.norm(c, axis=0), 1e-300), row_groups)
        observable = np.linalg.matrix_rank(np.vstack([block.rows(n) for n in range(N0)]), tol=1e-8) == L
        if np.linalg.matrix_rank(c) < L and observable:
            return block


def one_packet_case(i: int) -> tuple[PhaseBlock, list[MarkovChannel]]:
    rng = np.random.default_rng([SEED, i])
    block = random_degenerate_block(rng, n_rows=int(rng.choice([1, 1, 2, 3])))
    return block, [random_channel(rng, i % 3)]


def two_packet_case(i: int) -> tuple[PhaseBlock, list[MarkovChannel]]:
    rng = np.random.default_rng([SEED, 1000 + i])
    block = random_degenerate_block(rng, n_rows=int(rng.integers(1, 3)), groups=2)
    orders = [(0, 0), (0, 1), (1, 1), (1, 0)][i % 4]
    return block, [random_channel(rng, k) for k in orders]


@pytest.mark.parametrize("i", range(100))
def test_one_packet_matches_bruteforce(i: int) -> None:
    block, channels = one_packet_case(i)
    res = compute_sigma(block, channels)
    assert abs(res.sigma - oracle_sigma(block, channels)) <= TOL
    assert abs(res.rho_period - res.sigma**res.period) <= 1e-12


@pytest.mark.parametrize("i", range(24))
def test_two_packets_match_bruteforce(i: int) -> None:
    block, channels = two_packet_case(i)
    res = compute_sigma(block, channels)
    assert abs(res.sigma - oracle_sigma(block, channels)) <= TOL
    assert res.maximal_blind_sets, "several packets: every maximal blind set is enumerated"


def test_bruteforce_dp_matches_sequence_enumeration() -> None:
    """The oracle's DP itself: against summing over all ``2^t`` arrival sequences."""
    block, _ = one_packet_case(1)
    channel = random_channel(np.random.default_rng(SEED), 2)
    dp = BlindDP(block, [channel])
    t = 9
    total = 0.0
    for h0 in range(4):
        for seq in itertools.product((0, 1), repeat=t):
            p, h, covered = 0.25, h0, set()
            for step, g in enumerate(seq):
                p1 = float(channel.table[h])
                p *= p1 if g else 1 - p1
                h = ((h << 1) | g) & 3
                if g:
                    covered.add(step % block.base_period)
            rows = [block.rows(n) for n in sorted(covered)]
            rank = np.linalg.matrix_rank(np.vstack(rows), tol=1e-8) if rows else 0
            total += p if rank < block.n_columns else 0.0
    assert dp.blind_probability(t) == pytest.approx(total, rel=1e-12)
