"""Ranks modulo a prime of degree one (``kfio.structure._modp``) against exact ranks over the number field.

The reduction may only lose rank, never gain it, and the exact rank oracle
of a phase block must answer the same with it as without it.
"""

from __future__ import annotations

import itertools
import random

import pytest
from sympy import QQ, Rational, cos, pi, sqrt
from sympy.polys.matrices import DomainMatrix

from kfio.search._blind import SlotSpace
from kfio.structure import _fmo
from kfio.structure._modp import ModP

from support.blind_blocks import bench_block

FIELDS = [
    QQ,
    QQ.algebraic_field(sqrt(2) + sqrt(3)),
    QQ.algebraic_field(2 * cos(2 * pi / 7)),
    QQ.algebraic_field(sqrt(-5)),
]


def random_element(K, rng: random.Random):
    if K == QQ:
        return QQ(rng.randint(-3, 3), rng.randint(1, 3))
    d = K.mod.degree()
    return K.new([QQ(rng.randint(-2, 2), rng.choice([1, 1, 2, 3])) for _ in range(d)])


@pytest.mark.parametrize("i", range(40))
def test_rank_mod_p_never_exceeds_and_usually_equals_the_exact_rank(i: int) -> None:
    rng = random.Random(i)
    K = FIELDS[i % len(FIELDS)]
    red = ModP.for_field(K)
    assert red is not None
    rows, cols = rng.randint(1, 6), rng.randint(1, 5)
    M = [[random_element(K, rng) for _ in range(cols)] for _ in range(rows)]
    if i % 3 == 0 and rows > 1:
        M[-1] = [M[0][j] * K.convert(Rational(2)) - M[1 % rows][j] for j in range(cols)]  # a dependent row
    exact = int(DomainMatrix(M, (rows, cols), K).rank())
    mod = red.rank([[red.element(x) for x in row] for row in M], cols)
    assert mod <= exact
    assert mod == exact  # a 61-bit prime: a coincidence would need a minor divisible by it


def test_reduction_is_a_ring_homomorphism() -> None:
    rng = random.Random(7)
    for K in FIELDS:
        red = ModP.for_field(K)
        assert red is not None
        for _ in range(20):
            a, b = random_element(K, rng), random_element(K, rng)
            ra, rb = red.element(a), red.element(b)
            assert ra is not None and rb is not None
            assert red.element(a * b) == ra * rb % red.p
            assert red.element(a + b) == (ra + rb) % red.p


def test_a_denominator_divisible_by_p_does_not_reduce() -> None:
    red = ModP.for_field(QQ.algebraic_field(sqrt(2)))
    assert red is not None
    assert red.reduce([QQ(1, red.p), QQ(1)]) is None
    assert red.reduce([QQ(1, 2), QQ(1)]) is not None
    assert red.matrix([[QQ(1, 2), QQ(3)], [QQ(1, red.p), QQ(1)]]) is None
    assert red.matrix([[QQ(1, 2), QQ(3)]]) == [[pow(2, -1, red.p), 3]]


@pytest.mark.parametrize("factors,dense", [((15,), True), ((3, 4), True), ((4, 9), True), ((21,), False)])
def test_block_oracle_answers_the_same_without_the_prime(
    factors: tuple[int, ...], dense: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(_fmo, "_cyclotomic_oracle", lambda *args: None)  # the SymPy route's oracle
    block = bench_block(factors, dense)
    oracle = block.exact_rank
    assert oracle is not None and oracle._modp is not None
    space = SlotSpace.from_block(block)
    rng = random.Random(len(factors) * 100 + factors[0])
    slots = [(n, g) for n in range(space.n_phases) for g in range(space.n_groups)]
    picks = [sorted(rng.sample(slots, k)) for k in (1, 3, space.n_columns - 1, space.n_columns, space.n_columns + 2)]
    picks += [slots[: space.n_columns], slots]
    with_prime = [oracle(s) for s in picks]
    oracle._modp = None
    assert [oracle(s) for s in picks] == with_prime
    assert any(r == space.n_columns for r in with_prime) and any(r < space.n_columns for r in with_prime)


def test_subsets_of_a_small_block_agree(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(_fmo, "_cyclotomic_oracle", lambda *args: None)  # the SymPy route's oracle
    block = bench_block((3, 4), dense=True)
    oracle = block.exact_rank
    slots = [(n, g) for n in range(12) for g in range(2)]
    picks = [list(c) for c in itertools.islice(itertools.combinations(slots, 4), 0, 400, 7)]
    with_prime = [oracle(s) for s in picks]
    oracle._modp = None
    assert [oracle(s) for s in picks] == with_prime
