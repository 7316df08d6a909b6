"""``sigma_k`` of the degenerate ``N = 60`` block under Markov channels, and the bounds that make it fast.

The block is the last case of ``bench/bench_verdict.py``: ``A = 2 blkdiag(rotation
of order 3, rotation of order 4, companion of Phi_5)``, ``C = [1 0 1 0 1 0 0 0]``
(``N0 = 60``, ``L = 8``, window ``W = 8``), built by :mod:`kfio.structure._fmo` with
its exact rank oracle over ``Q(zeta_60)``.  The brute force of
:mod:`bruteforce` cannot reach ``N0 = 60`` (``2^60`` covered sets), so the
branch and bound is checked against its own reference route (no renewal
score, no window program: the search as it was before them, about 20 s of
CPU for Gilbert-Elliott) and the bounds are checked against every phase
pattern of small blocks.  Once, outside the tests, every one of the 51 059
shift orbits of maximal blind sets of this block was enumerated (321 s) and
scored: the maxima agree with the values below.
"""

from __future__ import annotations

import functools
import itertools
from fractions import Fraction as F

import numpy as np
import pytest

from kfio._budget import Budget
from kfio.model._types import MarkovChannel, System
from kfio.search._blind import Margins, SlotSpace, search
from kfio.sigma._sigma import (
    _LogRho,
    _objective,
    _RenewalScore,
    _step_matrices,
    _WindowBound,
    compute_sigma,
    period_transfer_matrix,
)
from kfio.structure._fmo import fmo_blocks
from kfio.structure._phases import PhaseBlock

#: bench_verdict's bursty Gilbert-Elliott channel: failure p = 1/10, recovery q = 3/10 (table (q, 1 - p)).
GE_BURSTY = MarkovChannel("gilbert_elliott", 1, (F(3, 10), F(9, 10)))
ORDER2 = MarkovChannel("markov", 2, (F(3, 10), F(9, 10), F(1, 5), F(4, 5)))
ORDER3 = MarkovChannel("markov", 3, tuple(F(k + 2, 12) for k in range(8)))


@functools.lru_cache(maxsize=1)
def period60_block() -> PhaseBlock:
    rot3 = [[-1, -3], [1, -1]]  # eigenvalues 2 exp(+-2 pi i / 3)
    rot4 = [[0, -2], [2, 0]]  # +-2i
    phi5 = [[0, 0, 0, -2], [2, 0, 0, -2], [0, 2, 0, -2], [0, 0, 2, -2]]  # 2 companion(x^4 + x^3 + x^2 + x + 1)
    A = [[0] * 8 for _ in range(8)]
    for offset, blk in ((0, rot3), (2, rot4), (4, phi5)):
        for i, row in enumerate(blk):
            for j, x in enumerate(row):
                A[offset + i][offset + j] = x
    system = System(
        A=tuple(tuple(F(x) for x in row) for row in A), C=((F(1), F(0), F(1), F(0), F(1), F(0), F(0), F(0)),)
    )
    (block,) = [b.phase for b in fmo_blocks(system) if b.phase.base_period == 60]
    return block


def spectral_radius(P: list[list[F]]) -> float:
    return float(np.abs(np.linalg.eigvals(np.array(P, dtype=float))).max())


@pytest.mark.slow
@pytest.mark.parametrize("channel", [GE_BURSTY, ORDER2, ORDER3], ids=["gilbert_elliott", "order2", "order3"])
def test_period60_markov_in_a_few_thousand_steps(channel: MarkovChannel) -> None:
    # Before the renewal score and the window program, Gilbert-Elliott took about 20 s of CPU here
    # (24 000 flats) and order 2 about 13 s; the issue asks for N = 60 under 2 s.
    # Counted in budget steps (flats expanded plus exact checks), not seconds: about 1,300 now.
    block = period60_block()
    budget = Budget()
    res = compute_sigma(block, [channel], budget=budget)
    assert budget.steps <= 5_000, budget.steps
    assert res.period == 60 and res.degenerate and res.certified
    # The worst set repeats with period 5 and holds three residues mod 5 (36 phases); its rho is
    # that of the exact one-period transfer matrix.
    worst = {n for n, _ in res.worst_blind_set}
    assert len(worst) == 36 and all((n in worst) == (n % 5 in worst) for n in range(60))
    exact = spectral_radius(period_transfer_matrix(60, res.worst_blind_set, [channel]))
    assert res.rho_period == pytest.approx(exact, rel=1e-9)


def test_period60_gilbert_elliott_closed_form() -> None:
    # Renewal (a loss resets the history): with losses forced at two adjacent residues mod 5, a
    # period is 12 times (a loss right after a loss, then a loss 4 steps after a loss):
    # sigma^5 = (1 - q) (pi + (1 - pi) lambda^4), pi = p / (p + q) = 1/4, lambda = 1 - p - q = 3/5.
    # The seed-style set of non-adjacent residues gives f(1) f(2) < (1 - q) f(3): it is not the worst.
    res = compute_sigma(period60_block(), [GE_BURSTY])
    assert res.sigma == pytest.approx((0.7 * (0.25 + 0.75 * 0.6**4)) ** 0.2, rel=1e-12)
    missed = sorted({n % 5 for n in range(60)} - {n % 5 for n, _ in res.worst_blind_set})
    assert (missed[1] - missed[0]) % 5 in (1, 4)


def reference_rho(block: PhaseBlock, channel: MarkovChannel) -> float:
    """``rho(P_F)`` of the worst set found by the search without the renewal score and the window program."""
    space = SlotSpace.from_block(block)
    objective = _objective([channel], block.base_period, block.base_period, reference=True)
    found = search(space, Budget(max_steps=10**6), Margins(space.tol), objective)
    return spectral_radius(
        period_transfer_matrix(block.base_period, frozenset(space.slots(found.maximal[0])), [channel])
    )


@pytest.mark.parametrize(
    "channel",
    [
        pytest.param(GE_BURSTY, marks=pytest.mark.slow, id="gilbert_elliott"),
        pytest.param(ORDER2, marks=pytest.mark.slow, id="order2"),
        pytest.param(ORDER3, id="order3"),
    ],
)
def test_period60_agrees_with_reference_search(channel: MarkovChannel) -> None:
    block = period60_block()
    res = compute_sigma(block, [channel])
    assert res.rho_period == pytest.approx(reference_rho(block, channel), rel=1e-9)


def random_channel(rng: np.random.Generator, order: int) -> MarkovChannel:
    return MarkovChannel("markov", order, tuple(F(int(x), 100) for x in rng.integers(3, 98, size=1 << order)))


@pytest.mark.parametrize("seed", range(40))
def test_window_program_bounds_every_pattern(seed: int) -> None:
    # M(c) must bound log rho(P_F) of every cyclic pattern all of whose windows of W phases miss
    # >= c phases: checked against all 2^N0 patterns, after one and after two rounds of x0.
    rng = np.random.default_rng([7, seed])
    channel = random_channel(rng, seed % 4)
    N0 = int(rng.integers(2, 11))
    W = int(rng.integers(2, N0 + 1))
    patterns = np.array(list(itertools.product([True, False], repeat=N0)))  # True: arrivals allowed
    log_rho = _LogRho([channel], N0, N0)(patterns)
    missed = ~patterns
    fewest = np.stack([missed[:, (np.arange(W) + s) % N0].sum(axis=1) for s in range(N0)], axis=1).min(axis=1)
    bound = _WindowBound(*_step_matrices(channel), N0, 1)
    for c in range(1, W + 1):
        truth = log_rho[fewest >= c].max(initial=-np.inf)
        for rounds in (1, 2):
            assert bound.max_log_rho(W, c, rounds) >= truth - 1e-9 * max(1.0, abs(truth))


@pytest.mark.parametrize("seed", range(10))
def test_renewal_score_is_exact_for_order_one(seed: int) -> None:
    rng = np.random.default_rng([11, seed])
    channel = random_channel(rng, 1)
    N0 = int(rng.integers(1, 40))
    masks = rng.random((64, N0)) < rng.random((64, 1))
    masks[0], masks[1] = True, False  # nothing missed (rho = 1) and everything missed
    expected = _LogRho([channel], N0, N0)(masks)
    assert np.abs(_RenewalScore(channel, N0, 1)(masks) - expected).max() <= 1e-9 * max(1.0, np.abs(expected).max())
