"""``sigma_k`` (Rohr, Marelli and Fu (2014), Lemmas 2-3, Corollary 2): worked examples, special cases, exact pieces.

Reference values are derived in the comments and checked against the brute
force of :mod:`bruteforce` wherever a seed's own arithmetic is involved.
"""

from __future__ import annotations

import itertools
import math
from fractions import Fraction as F

import numpy as np
import pytest
import sympy
from sympy import QQ
from sympy.polys.matrices import DomainMatrix

from kfio._budget import Budget
from kfio.errors import AssumptionViolation, BudgetExceeded, InvalidInput, NumericalFailure
from kfio.model._types import MarkovChannel
from kfio.search._blind import Margins, SlotSpace
from kfio.sigma._sigma import compute_sigma, period_transfer_matrix, sigma_period
from kfio.structure._phases import PhaseBlock

from support.bruteforce import oracle_sigma


def bernoulli(lam: F) -> MarkovChannel:
    return MarkovChannel("bernoulli", 0, (lam,))


def gilbert_elliott(p: F, q: F) -> MarkovChannel:
    """``p`` failure rate, ``q`` recovery rate (Rohr, Marelli and Fu (2014), Remark 1): table ``(q, 1 - p)``."""
    return MarkovChannel("gilbert_elliott", 1, (q, 1 - p))


def markov(table: tuple[F, ...]) -> MarkovChannel:
    return MarkovChannel("markov", len(table).bit_length() - 1, table)


def cyclotomic_oracle(c_int: list[list[int]], exponents: tuple[int, ...], N0: int, groups: tuple[tuple[int, ...], ...]):
    """Exact rank over ``Q(zeta_N0)`` of the rows ``C diag(zeta^(e n))`` (integer ``C``, unscaled)."""
    if N0 <= 2:
        K, zeta = QQ, QQ(-1 if N0 == 2 else 1)
    else:
        K = QQ.algebraic_field(sympy.exp(2 * sympy.pi * sympy.I / N0))
        zeta = K.from_sympy(sympy.exp(2 * sympy.pi * sympy.I / N0))
    powers = [K.one]
    for _ in range(N0 - 1):
        powers.append(powers[-1] * zeta)

    def oracle(slots):
        rows = [
            [K.convert(c_int[i][j]) * powers[(e * n) % N0] for j, e in enumerate(exponents)]
            for n, g in slots
            for i in groups[g]
        ]
        return DomainMatrix(rows, (len(rows), len(exponents)), K).rank() if rows else 0

    return oracle


def block_of(c_int, exponents, N0, groups=None, exact=True) -> PhaseBlock:
    """A phase block with unit-norm columns (as :mod:`kfio.structure._fmo` builds them) and an exact oracle."""
    c = np.asarray(c_int, dtype=complex)
    groups = groups or (tuple(range(c.shape[0])),)
    oracle = cyclotomic_oracle(c_int, exponents, N0, groups) if exact else None
    return PhaseBlock(N0, tuple(exponents), c / np.maximum(np.linalg.norm(c, axis=0), 1e-300), groups, oracle)


#: Rohr, Marelli and Fu (2014), Example 1: ``A = alpha diag(1, -1)``, ``C = [1 1]``: omega = (1, -1), N0 = 2.
EXAMPLE1 = block_of([[1, 1]], (0, 1), 2)


def spectral_radius(P: list[list[F]]) -> float:
    return float(np.abs(np.linalg.eigvals(np.array(P, dtype=float))).max())


@pytest.mark.parametrize("lam", [F(1, 10), F(1, 2), F(9, 10)])
def test_example3_bernoulli(lam: F) -> None:
    # Rohr, Marelli and Fu (2014), Example 3, eq. (35): sigma = (1 - lambda)^(1/2); blind sets {0}, {1} (Corollary 2).
    res = compute_sigma(EXAMPLE1, [bernoulli(lam)])
    assert res.period == 2 and res.degenerate and not res.fully_blind
    assert res.sigma == pytest.approx(float(1 - lam) ** 0.5, rel=1e-14)
    assert res.rho_period == pytest.approx(float(1 - lam), rel=1e-14)
    assert res.bernoulli_exponents == (F(1, 2),)
    assert res.worst_blind_set in ({(0, 0)}, {(1, 0)})
    assert res.certified


@pytest.mark.parametrize("p", [F(1, 10), F(1, 2), F(9, 10)])
@pytest.mark.parametrize("q", [F(1, 10), F(1, 2), F(9, 10)])
def test_example2_gilbert_elliott(p: F, q: F) -> None:
    # Rohr, Marelli and Fu (2014), Example 2 has an arithmetic slip: it writes D_3 = (1-q)^2 + q(1-q) = 1-q and
    # concludes sigma^2 = max{1-q, (1-q)^2 + pq}.  After the arrival at the free phase the next
    # loss has probability p (the failure rate), not 1-q, so D_3 = (1-q)^2 + pq = D_2's Perron
    # root, as shift invariance of blind sets demands ({0} and {1} are shifts of each other).
    # The truth, confirmed by the brute force below, is sigma^2 = (1-q)^2 + pq for all p, q.
    truth = float((1 - q) ** 2 + p * q)
    res = compute_sigma(EXAMPLE1, [gilbert_elliott(p, q)])
    assert res.sigma**2 == pytest.approx(truth, rel=1e-12)
    assert oracle_sigma(EXAMPLE1, [gilbert_elliott(p, q)]) ** 2 == pytest.approx(truth, rel=1e-9)
    if p < 1 - q:  # where the seed's formula would give 1 - q instead
        assert res.sigma**2 < float(1 - q) - 1e-3


@pytest.mark.parametrize(
    "channel",
    [bernoulli(F(3, 10)), gilbert_elliott(F(1, 5), F(2, 5)), markov((F(1, 3), F(1, 2), F(3, 4), F(9, 10)))],
    ids=["bernoulli", "gilbert_elliott", "order2"],
)
def test_non_degenerate_is_lemma2(channel: MarkovChannel) -> None:
    # Rohr, Marelli and Fu (2014), Lemma 2: only the empty set is blind, sigma = P(g = 0 | nu zeros) = 1 - table[0].
    block = block_of([[1, 0], [1, 1]], (0, 1), 2)
    res = compute_sigma(block, [channel])
    assert not res.degenerate and not res.fully_blind
    assert res.sigma == float(1 - channel.table[0])
    assert res.worst_blind_set == frozenset() and res.maximal_blind_sets == (frozenset(),)
    assert res.certified
    assert abs(res.sigma - oracle_sigma(block, [channel])) <= 1e-9


@pytest.mark.parametrize(
    ("c_int", "exponents"),
    [([[1, 0]], (0, 1)), ([[1, 2]], (1, 1)), ([[1, 1, 1]], (0, 2, 0))],
    ids=["unobserved-column", "one-eigenvalue-two-chains", "repeat-in-three"],
)
def test_fully_blind_has_sigma_one(c_int, exponents) -> None:
    block = block_of(c_int, exponents, 4)
    res = compute_sigma(block, [bernoulli(F(1, 2))])
    assert res.fully_blind and res.degenerate
    assert res.sigma == 1.0 and res.rho_period == 1.0
    assert res.worst_blind_set == {(n, 0) for n in range(4)}
    assert res.bernoulli_exponents == (F(0),)
    assert res.certified


def test_period_longer_than_base_period() -> None:
    # Example 1 (N0 = 2) under an order-3 channel: N = 4 >= nu.
    channel = markov(tuple(F(k + 1, 10) for k in range(8)))
    res = compute_sigma(EXAMPLE1, [channel])
    assert res.period == sigma_period(2, [channel]) == 4
    assert all(0 <= n < 4 for n, _ in res.worst_blind_set)
    assert {((n + 2) % 4, g) for n, g in res.worst_blind_set} == res.worst_blind_set
    assert abs(res.sigma - oracle_sigma(EXAMPLE1, [channel])) <= 1e-6
    assert spectral_radius(period_transfer_matrix(4, res.worst_blind_set, [channel])) == pytest.approx(
        res.rho_period, rel=1e-9
    )


def test_period_longer_than_base_period_two_packets() -> None:
    # Representatives of maximal blind sets live on [0, N) and repeat with period N0.
    block = block_of([[1, 1], [1, 2]], (0, 1), 2, groups=((0,), (1,)))
    channels = [markov(tuple(F(k + 2, 12) for k in range(8))), bernoulli(F(1, 3))]
    res = compute_sigma(block, channels)
    assert res.period == 4 and res.maximal_blind_sets
    for S in res.maximal_blind_sets:
        assert all(0 <= n < 4 for n, _ in S) and {((n + 2) % 4, g) for n, g in S} == S
    assert abs(res.sigma - oracle_sigma(block, channels)) <= 1e-6


@pytest.mark.parametrize(("N0", "nu", "N"), [(1, 0, 1), (3, 0, 3), (2, 3, 4), (4, 5, 8), (5, 5, 5)])
def test_sigma_period(N0: int, nu: int, N: int) -> None:
    assert sigma_period(N0, [markov(tuple(F(1, 2) for _ in range(1 << nu)))]) == N


def test_markov_worst_set_need_not_be_largest() -> None:
    # Maximal blind orbits {0,1,2}, {0,1,3,4}, {0,2,4}; an alternating channel (p = q = 9/10)
    # favours {0,2,4} although {0,1,3,4} is larger: sigma is a spectral radius, not a count.
    block = block_of([[-1, -2, 2, 1]], (4, 0, 2, 3), 6)
    channel = gilbert_elliott(F(9, 10), F(9, 10))
    res = compute_sigma(block, [channel])
    assert len(res.worst_blind_set) == 3 and {(n + 2) % 6 for n, _ in res.worst_blind_set} == {
        n for n, _ in res.worst_blind_set
    }
    assert abs(res.sigma - oracle_sigma(block, [channel])) <= 1e-6
    largest = frozenset({(0, 0), (1, 0), (3, 0), (4, 0)})
    assert spectral_radius(period_transfer_matrix(6, largest, [channel])) < res.rho_period


def test_bernoulli_exponent_form_two_packets() -> None:
    # Two sensors seeing Example 1's modes: sigma = prod_g (1 - lambda_g)^(z_g / N).
    block = block_of([[1, 1], [1, 2]], (0, 1), 2, groups=((0,), (1,)))
    lams = (F(1, 5), F(2, 3))
    channels = [bernoulli(lam) for lam in lams]
    res = compute_sigma(block, channels)
    assert res.bernoulli_exponents is not None
    closed = math.prod(float(1 - lam) ** float(z) for lam, z in zip(lams, res.bernoulli_exponents))
    assert res.sigma == pytest.approx(closed, rel=1e-14)
    assert abs(res.sigma - oracle_sigma(block, channels)) <= 1e-6
    by_set = [
        math.prod(float(1 - lam) ** (2 - sum(1 for _, g in S if g == k)) for k, lam in enumerate(lams))
        for S in res.maximal_blind_sets
    ]
    assert res.rho_period == pytest.approx(max(by_set), rel=1e-12)
    assert res.certified


def orbit(S, N0: int) -> frozenset:
    return frozenset(frozenset(((n + k) % N0, g) for n, g in S) for k in range(N0))


def maximal_blind_by_subsets(block: PhaseBlock) -> set[frozenset]:
    """All maximal blind sets over ``[0, N0) x groups`` by trying all ``2^S`` subsets (tiny blocks only)."""
    slots = [(n, g) for n in range(block.base_period) for g in range(len(block.row_groups))]
    L = block.n_columns
    blind = [
        frozenset(S)
        for k in range(len(slots) + 1)
        for S in itertools.combinations(slots, k)
        if np.linalg.matrix_rank(block.stacked(S), tol=1e-8) < L
    ]
    return {S for S in blind if not any(S < T for T in blind)}


#: Small several-sensor blocks: ``(C rows, phase exponents, N0, sensor row groups)``.
SENSOR_BLOCKS = [
    ([[1, 1], [1, 2]], (0, 1), 2, ((0,), (1,))),
    ([[1, 1, 1], [1, -1, 2]], (0, 1, 3), 4, ((0,), (1,))),
    ([[1, 2, 0], [0, 1, 1], [1, 0, 1]], (0, 2, 1), 3, ((0,), (1, 2))),
    ([[1, 1, 1, 1], [2, 1, 0, 1]], (0, 2, 3, 1), 4, ((0,), (1,))),
]


@pytest.mark.parametrize(("c_int", "exponents", "N0", "groups"), SENSOR_BLOCKS)
def test_enumerated_maximal_blind_sets_are_all_orbits(c_int, exponents, N0, groups) -> None:
    # A Markov channel: sigma depends on where the misses fall, so every orbit is enumerated.
    block = block_of(c_int, exponents, N0, groups)
    res = compute_sigma(block, [gilbert_elliott(F(1, 3), F(1, 4))] + [bernoulli(F(1, 2)) for _ in groups[1:]])
    expected = {orbit(S, N0) for S in maximal_blind_by_subsets(block)}
    got = [orbit(S, N0) for S in res.maximal_blind_sets]
    assert len(got) == len(set(got)), "one representative per shift orbit"
    assert set(got) == expected


def miss_vector(S, N0: int, groups: int) -> tuple[int, ...]:
    return tuple(N0 - sum(1 for n, g in S if g == k and n < N0) for k in range(groups))


@pytest.mark.parametrize(
    ("c_int", "exponents", "N0", "groups"),
    [*SENSOR_BLOCKS, ([[1, 1, 1], [1, -1, 2], [2, 0, 1]], (0, 1, 3), 4, ((0,), (1,), (2,)))],
)
def test_bernoulli_sensors_keep_one_set_per_undominated_miss_vector(c_int, exponents, N0, groups) -> None:
    # Bernoulli sensors: only componentwise-minimal miss vectors can matter (Corollary 2).
    block = block_of(c_int, exponents, N0, groups)
    res = compute_sigma(block, [bernoulli(F(1, 2)) for _ in groups])
    maximal = maximal_blind_by_subsets(block)
    vectors = {miss_vector(S, N0, len(groups)) for S in maximal}
    expected = {z for z in vectors if not any(w != z and all(a <= b for a, b in zip(w, z)) for w in vectors)}
    got = [miss_vector(S, N0, len(groups)) for S in res.maximal_blind_sets]
    assert sorted(got) == sorted(expected), "one set per undominated vector"
    base = {frozenset((n, g) for n, g in S if n < N0) for S in res.maximal_blind_sets}
    assert all(any(orbit(S, N0) == orbit(T, N0) for T in maximal) for S in base), "each is a maximal blind set"


@pytest.mark.parametrize(
    ("channels", "blind_set"),
    [
        ([gilbert_elliott(F(1, 3), F(1, 4))], frozenset({(0, 0), (2, 0)})),
        ([markov((F(1, 5), F(2, 5), F(3, 5), F(4, 5)))], frozenset({(1, 0)})),
        ([gilbert_elliott(F(1, 2), F(1, 3)), bernoulli(F(1, 4))], frozenset({(0, 0), (1, 1), (3, 1)})),
    ],
)
def test_period_transfer_matrix_is_exact(channels, blind_set) -> None:
    block = block_of(
        [[1, 1, 0, 1], [0, 1, 1, 1]][: len(channels)] if len(channels) > 1 else [[1, 1, 1, 1]],
        (0, 1, 2, 3),
        4,
        tuple((g,) for g in range(len(channels))),
        exact=False,
    )
    P = period_transfer_matrix(4, blind_set, channels)
    assert all(isinstance(x, F) for row in P for x in row)
    assert len(P) == math.prod(ch.n_histories for ch in channels)
    res = compute_sigma(block, channels)
    P_worst = period_transfer_matrix(res.period, res.worst_blind_set, channels)
    assert spectral_radius(P_worst) == pytest.approx(res.rho_period, rel=1e-9)
    # Row sums are the probabilities of staying inside the blind set for one period.
    assert all(sum(row) <= 1 for row in P)


def test_n0_60_block_in_a_few_thousand_steps() -> None:
    # 2 blkdiag(rotation of order 3, rotation of order 4, companion of Phi_5): N0 = 60, L = 8.
    # With one row the largest blind sets are {n : n mod 5 in a 3-set} (size 36), so
    # sigma = (1 - lambda)^(24/60) (Corollary 2).
    block = PhaseBlock(60, (20, 40, 15, 45, 12, 24, 36, 48), np.ones((1, 8), dtype=complex) / 8**0.5, ((0,),))
    budget = Budget()  # work counted in steps (about 1,000; 2^60 subsets by brute force), not seconds
    res = compute_sigma(block, [bernoulli(F(1, 2))], budget=budget)
    assert budget.steps <= 5_000, budget.steps
    assert res.bernoulli_exponents == (F(2, 5),)
    assert res.sigma == pytest.approx(0.5**0.4, rel=1e-14)
    assert not res.certified and any("numerical" in note for note in res.notes)
    worst = sorted(res.worst_blind_set)
    assert np.linalg.matrix_rank(block.stacked(worst), tol=1e-8) == 7
    residues = {n % 5 for n, _ in worst}
    assert len(residues) == 3 and all(n % 5 in residues for n in range(60) if (n, 0) in res.worst_blind_set)


def test_budget_exceeded_instead_of_hanging() -> None:
    block = PhaseBlock(60, (20, 40, 15, 45, 12, 24, 36, 48), np.ones((1, 8), dtype=complex) / 8**0.5, ((0,),))
    with pytest.raises(BudgetExceeded, match="sigma"):
        compute_sigma(block, [bernoulli(F(1, 2))], Budget(max_steps=20))


@pytest.mark.parametrize("shift", [1, 3])
def test_invariant_under_rotation_scaling_and_column_order(shift: int) -> None:
    # omega -> omega * zeta^shift (another choice of alpha), row scaling of C, permuted columns.
    base = block_of([[1, 2, -1, 1], [0, 1, 1, 2]], (0, 1, 2, 4), 6, exact=False)
    channel = gilbert_elliott(F(1, 4), F(1, 3))
    moved = PhaseBlock(
        6,
        tuple((e + shift) % 6 for e in base.exponents[::-1]),
        (np.diag([3.0, -0.5]) @ base.c_hat)[:, ::-1],
        base.row_groups,
    )
    assert compute_sigma(moved, [channel]).sigma == pytest.approx(compute_sigma(base, [channel]).sigma, rel=1e-12)


def test_certification_uses_the_exact_oracle() -> None:
    channel = gilbert_elliott(F(1, 3), F(1, 5))
    exact = compute_sigma(block_of([[1, 1, 1], [1, -1, 2]], (0, 1, 3), 4), [channel])
    assert exact.certified and any("certified" in note for note in exact.notes)
    numeric = compute_sigma(block_of([[1, 1, 1], [1, -1, 2]], (0, 1, 3), 4, exact=False), [channel])
    assert not numeric.certified and any("numerical" in note for note in numeric.notes)
    assert numeric.sigma == exact.sigma


def test_oracle_without_answer_is_not_certified() -> None:
    block = PhaseBlock(2, (0, 1), np.array([[1.0, 1.0]]) / 2**0.5, ((0,),), lambda slots: None)
    res = compute_sigma(block, [bernoulli(F(1, 2))])
    assert not res.certified and any("no answer" in note for note in res.notes)


def test_contradicting_oracle_raises() -> None:
    block = PhaseBlock(2, (0, 1), np.array([[1.0, 1.0]]) / 2**0.5, ((0,),), lambda slots: 2)
    with pytest.raises(NumericalFailure, match="contradicts"):
        compute_sigma(block, [bernoulli(F(1, 2))])


def test_input_errors() -> None:
    with pytest.raises(InvalidInput, match="one channel per packet"):
        compute_sigma(EXAMPLE1, [bernoulli(F(1, 2)), bernoulli(F(1, 2))])
    with pytest.raises(AssumptionViolation, match="Assumption 1"):
        compute_sigma(EXAMPLE1, [gilbert_elliott(F(0), F(1, 2))])
    with pytest.raises(InvalidInput, match="not finite"):
        compute_sigma(PhaseBlock(2, (0, 1), np.array([[np.nan, 1.0]]), ((0,),)), [bernoulli(F(1, 2))])
    with pytest.raises(InvalidInput, match="at least one column"):
        compute_sigma(PhaseBlock(1, (), np.zeros((1, 0)), ((0,),)), [bernoulli(F(1, 2))])


def test_slot_space_ranks() -> None:
    space = SlotSpace.from_block(EXAMPLE1)
    margins = Margins(space.tol)
    assert space.rank(space.mask([]), margins) == 0
    assert space.rank(space.mask([(0, 0)]), margins) == 1
    assert space.rank(space.mask([(0, 0), (3, 0)]), margins) == 2  # phase 3 is phase 1 (mod N0 = 2)
    assert space.window(margins) == 2
