"""Benchmark: ``compute_sigma`` against the naive ``2^N`` subset enumeration.

Run ``python bench/bench_sigma.py`` from the repository root.  For each
degenerate block (one output row, eigenvalues ``2 * roots of unity`` of the
orders in its name) it times :func:`kfio.sigma._sigma.compute_sigma` (median of
three runs) and a naive baseline that tries every subset of the ``N`` phases
with a numpy rank test, keeps the maximal blind ones and scores them.  The
baseline is run where ``N <= 16``; beyond that its time is extrapolated as
``2^N`` times the measured cost of one rank test (a lower bound: it leaves
out finding the maximal sets), and the table says so.  The "reference"
column times the branch and bound without the renewal score and the window
program (the search as it was before them; same for Bernoulli) with a 60 s
budget.  A last column times the enumeration of every shift orbit of
maximal blind sets (what several packets need) with a 20 s budget.
"""

from __future__ import annotations

import math
import statistics
import sys
import time
from fractions import Fraction
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from kfio._budget import Budget  # noqa: E402
from kfio.errors import BudgetExceeded  # noqa: E402
from kfio.model._types import MarkovChannel  # noqa: E402
from kfio.search._blind import Margins, SlotSpace, search  # noqa: E402
from kfio.sigma._sigma import _objective, compute_sigma, sigma_period  # noqa: E402
from kfio.structure._phases import PhaseBlock  # noqa: E402

NAIVE_MAX_N = 16
ENUMERATION_SECONDS = 20.0
REFERENCE_SECONDS = 60.0


def primitive_exponents(N0: int, orders: tuple[int, ...]) -> tuple[int, ...]:
    """Exponents ``k N0 / m`` of all primitive ``m``-th roots of unity, for each ``m`` in ``orders``."""
    return tuple(k * (N0 // m) for m in orders for k in range(m) if math.gcd(k, m) == 1)


def block(orders: tuple[int, ...]) -> PhaseBlock:
    N0 = math.lcm(*orders)
    exponents = primitive_exponents(N0, orders)
    L = len(exponents)
    return PhaseBlock(N0, exponents, np.ones((1, L), dtype=complex) / math.sqrt(L), ((0,),))


CHANNELS = {
    "bernoulli(1/2)": MarkovChannel("bernoulli", 0, (Fraction(1, 2),)),
    "GE(p=3/10,q=2/5)": MarkovChannel("gilbert_elliott", 1, (Fraction(2, 5), Fraction(7, 10))),
    # bench_verdict's bursty channel: failure 1/10, recovery 3/10.
    "GE(p=1/10,q=3/10)": MarkovChannel("gilbert_elliott", 1, (Fraction(3, 10), Fraction(9, 10))),
    # P(arrival | h) for the histories 00, 01, 10, 11 (g[t-2] g[t-1]).
    "order2(3,9,2,8)/10": MarkovChannel(
        "markov", 2, (Fraction(3, 10), Fraction(9, 10), Fraction(2, 10), Fraction(8, 10))
    ),
}

#: Orders of the roots of unity omega_j (all primitive ones of each order): ``(1, 2)`` is Rohr, Marelli and Fu (2014)'s
#: Example 1, ``(3, 4, 5)`` is 2 blkdiag(rotation of order 3, rotation of order 4, companion of Phi_5).
BLOCKS = [(1, 2), (3, 4), (3, 5), (2, 8), (2, 3, 5), (4, 9), (3, 4, 5), (3, 4, 7)]


def time_ours(blk: PhaseBlock, channel: MarkovChannel) -> tuple[float, float, float]:
    """Median wall and CPU seconds of three runs (CPU time is what a loaded, shared machine distorts least)."""
    wall, cpu, sigma = [], [], 0.0
    for _ in range(3):
        start, start_cpu = time.perf_counter(), time.process_time()
        sigma = compute_sigma(blk, [channel]).sigma
        wall.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    return statistics.median(wall), statistics.median(cpu), sigma


def time_reference(blk: PhaseBlock, channel: MarkovChannel) -> str:
    """CPU seconds of the branch and bound without the renewal score and the window program."""
    space = SlotSpace.from_block(blk)
    objective = _objective([channel], blk.base_period, sigma_period(blk.base_period, [channel]), reference=True)
    start = time.process_time()
    try:
        search(space, Budget(seconds=REFERENCE_SECONDS), Margins(space.tol), objective)
    except BudgetExceeded:
        return f"> {REFERENCE_SECONDS:g}"
    return f"{time.process_time() - start:.4f}"


def rho_float(channel: MarkovChannel, allowed: list[bool]) -> float:
    """``rho`` of the one-period product (plain float loop: the naive way)."""
    k = channel.n_histories
    P = np.eye(k)
    for ok in allowed:
        T = np.zeros((k, k))
        for h in range(k):
            p1 = float(channel.table[h])
            T[h, channel.next_history(h, 0)] += 1 - p1
            if ok:
                T[h, channel.next_history(h, 1)] += p1
        P = P @ T
    return float(np.abs(np.linalg.eigvals(P)).max())


def naive(blk: PhaseBlock, channel: MarkovChannel, N: int) -> float:
    """sigma by trying all ``2^N`` subsets of phases."""
    L = blk.n_columns
    rows = [blk.rows(n) for n in range(N)]
    blind = []
    for mask in range(1 << N):
        chosen = [rows[n] for n in range(N) if mask >> n & 1]
        if not chosen or np.linalg.matrix_rank(np.vstack(chosen), tol=1e-8) < L:
            blind.append(mask)
    blind_set = set(blind)
    maximal = [m for m in blind if not any((m | 1 << n) in blind_set for n in range(N) if not m >> n & 1)]
    best = max(rho_float(channel, [bool(m >> n & 1) for n in range(N)]) for m in maximal)
    return best ** (1 / N)


def rank_test_cost(blk: PhaseBlock, N: int, samples: int = 2000) -> float:
    rng = np.random.default_rng(0)
    rows = [blk.rows(n) for n in range(N)]
    start = time.perf_counter()
    for _ in range(samples):
        chosen = [rows[n] for n in np.flatnonzero(rng.random(N) < 0.5)] or rows[:1]
        np.linalg.matrix_rank(np.vstack(chosen), tol=1e-8)
    return (time.perf_counter() - start) / samples


def time_enumeration(blk: PhaseBlock) -> str:
    """Seconds to enumerate every shift orbit of maximal blind sets, and how many there are."""
    space = SlotSpace.from_block(blk)
    start = time.perf_counter()
    try:
        found = search(space, Budget(seconds=ENUMERATION_SECONDS), Margins(space.tol))
    except BudgetExceeded:
        return f"> {ENUMERATION_SECONDS:g}"
    return f"{time.perf_counter() - start:.3g} ({len(found.maximal)})"


def main() -> None:
    header = (
        "| orders | N | L | channel | reference cpu [s] | compute_sigma wall [s] | cpu [s] | naive 2^N [s] | naive "
        "| ratio | sigma | all orbits [s] (count) |"
    )
    print(header)
    print("|" + "---|" * 12)
    for orders in BLOCKS:
        blk = block(orders)
        N, L = blk.base_period, blk.n_columns
        enumeration = time_enumeration(blk)
        for name, channel in CHANNELS.items():
            reference = time_reference(blk, channel)
            ours, cpu, sigma = time_ours(blk, channel)
            if N <= NAIVE_MAX_N:
                start = time.perf_counter()
                sigma_naive = naive(blk, channel, N)
                base = time.perf_counter() - start
                how = "measured"
                assert abs(sigma_naive - sigma) < 1e-9, (orders, name, sigma, sigma_naive)
            else:
                base = 2.0**N * rank_test_cost(blk, N)
                how = "extrapolated"
            print(
                f"| {'x'.join(map(str, orders))} | {N} | {L} | {name} | {reference} | {ours:.4f} | {cpu:.4f} | "
                f"{base:.3g} | {how} | {base / ours:.3g} | {sigma:.6f} | {enumeration} |"
            )


if __name__ == "__main__":
    main()
