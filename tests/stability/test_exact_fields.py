"""Every exact field of the verdict is exact.

``critical_arrival_probability_exact`` and ``sigma_exact`` used to be
rewritten by ``nsimplify`` (PSLQ on floats), which returned wrong numbers for
ordinary inputs.  Here each exact field is compared with an independent exact
computation: closed forms of Rohr, Marelli and Fu (2014), Lemma 2 and
Corollary 2, worked out in :class:`fractions.Fraction` for the structure at
hand (rational where the answer is rational); where the answer is a radical,
its minimal polynomial (SymPy's ``minimal_polynomial``) and a 40-digit value
(which isolates it among the polynomial's roots).  The float fields must
agree with the exact ones, and ``sigma`` with the brute-force oracle.
"""

from __future__ import annotations

import json
import random
from fractions import Fraction as F

import mpmath
import pytest
import sympy

from kfio import analyze, load_request
from kfio.model._exact import fraction_text
from kfio.stability._radicals import RealRadical
from kfio.structure._fmo import fmo_blocks

from support.bruteforce import oracle_sigma

X = sympy.Symbol("x")


def _bern(lam: F) -> dict:
    return {"model": "bernoulli", "arrival_probability": fraction_text(lam)}


def _run(A, C, lam: F):
    body = {"system": {"A": A, "C": C}, "channel": _bern(lam)}
    return analyze(load_request(json.dumps(body)))


def _text(x: F) -> str:
    return fraction_text(x)


def _awkward_rational(rng: random.Random) -> F:
    """``|a| > 1`` with numerator and denominator of 1 to 40 digits."""
    while True:
        num = rng.randrange(1, 10 ** rng.randint(1, 40))
        den = rng.randrange(1, 10 ** rng.randint(1, 40))
        a = F(num, den) * rng.choice((1, -1))
        if abs(a) > 1 and abs(a) < 10**30:
            return a


def _probability(rng: random.Random) -> F:
    den = 10 ** rng.randint(1, 30)
    return F(rng.randrange(1, den), den)


def _same_algebraic(text: str, expected: sympy.Expr) -> bool:
    """``text`` (our own output, trusted) denotes ``expected``: same minimal polynomial, same value."""
    got = sympy.sympify(text)
    if sympy.minimal_polynomial(got, X) != sympy.minimal_polynomial(expected, X):
        return False
    return abs(sympy.N(got - expected, 60)) < sympy.Float(10) ** -45


# -- the reproducers of the issue ---------------------------------------------------


def test_large_scalar_gives_the_rational_critical_probability():
    r = _run([[10000]], [[1]], F(1, 2))
    assert r.critical_arrival_probability_exact == "99999999/100000000"
    assert r.critical_arrival_probability == float(F(99999999, 100000000))
    # and the verdict agrees with it: at lambda_c exactly, the theorem's gap
    assert _run([[10000]], [[1]], F(99999999, 100000000)).verdict == "boundary"
    assert _run([[10000]], [[1]], F(99999998, 100000000)).verdict == "unstable"


def test_awkward_scalar_gives_the_rational_critical_probability():
    r = _run([["559/134"]], [[1]], F(1, 2))
    expected = 1 - 1 / F(559, 134) ** 2
    assert expected == F(294525, 312481)
    assert r.critical_arrival_probability_exact == "294525/312481"
    assert r.critical_arrival_probability == float(expected)


def test_seed_2x2_sigma_is_one_minus_lambda():
    r = _run([[1.25, 0], [1, 1.1]], [[1, 1]], F(600053, 1000000))
    assert [b.sigma_exact for b in r.blocks] == ["399947/1000000"] * 2
    assert all(b.sigma == float(F(399947, 1000000)) for b in r.blocks)
    assert r.critical_arrival_probability_exact == "9/25"


def test_seed_2x2_over_many_probabilities():
    # the issue found 1 wrong sigma_exact in 180 probabilities; every one must be 1 - lambda (Lemma 2)
    rng = random.Random(12)
    for _ in range(60):
        lam = F(rng.randrange(360001, 999999), 1000000)
        r = _run([[1.25, 0], [1, 1.1]], [[1, 1]], lam)
        assert [b.sigma_exact for b in r.blocks] == [_text(1 - lam)] * 2
        assert r.critical_arrival_probability_exact == "9/25"


# -- randomized structures with closed forms -----------------------------------------


@pytest.mark.parametrize("seed", range(6))
def test_scalar_random_rationals(seed: int):
    # A = a: one non-degenerate block, sigma = 1 - lambda (Lemma 2), lambda_c = 1 - 1/a^2
    rng = random.Random(seed)
    a, lam = _awkward_rational(rng), _probability(rng)
    r = _run([[_text(a)]], [[1]], lam)
    (b,) = r.blocks
    assert b.sigma_exact == _text(1 - lam) and b.sigma == float(1 - lam)
    assert b.modulus_exact == _text(abs(a))
    assert r.critical_arrival_probability_exact == _text(1 - 1 / a**2)
    assert r.critical_arrival_probability == pytest.approx(float(1 - 1 / a**2), rel=1e-15)


@pytest.mark.parametrize("seed", range(4))
def test_mirror_pair_sigma_is_a_square_root(seed: int):
    # A = a diag(1, -1), C = [1 1]: degenerate, period 2, largest blind set one phase, so
    # sigma = (1 - lambda)^(1/2) and lambda_c = 1 - a^-4 (docs/theory.md)
    rng = random.Random(100 + seed)
    a, lam = _awkward_rational(rng), _probability(rng)
    if seed == 0:
        lam = F(1) - F(4, 9)  # sigma = 2/3 exactly: the radical must come out rational
    r = _run([[_text(a), 0], [0, _text(-a)]], [[1, 1]], lam)
    (b,) = r.blocks
    assert b.period == 2 and b.degenerate
    assert _same_algebraic(b.sigma_exact, sympy.sqrt(sympy.Rational(_text(1 - lam))))
    if seed == 0:
        assert b.sigma_exact == "2/3"
    assert b.sigma == pytest.approx(float(mpmath.sqrt(mpmath.mpf(_text(1 - lam)))), rel=1e-15)
    assert r.critical_arrival_probability_exact == _text(1 - 1 / a**4)


@pytest.mark.parametrize("seed", range(3))
def test_rotation_by_a_third_turn(seed: int):
    # A = a * companion(x^2 + x + 1): eigenvalues a w, a w^2 with w^3 = 1, period 3; with one output
    # row every single phase is blind and no pair is, so sigma = (1 - lambda)^(2/3) and
    # lambda_c = 1 - (a^2)^(-3/2) = 1 - |a|^-3
    rng = random.Random(200 + seed)
    a, lam = _awkward_rational(rng), _probability(rng)
    A = [["0", _text(-a)], [_text(a), _text(-a)]]
    r = _run(A, [[1, 0]], lam)
    (b,) = r.blocks
    assert b.period == 3 and b.degenerate
    expected = sympy.Rational(_text(1 - lam)) ** sympy.Rational(2, 3)
    assert _same_algebraic(b.sigma_exact, expected)
    assert r.critical_arrival_probability_exact == _text(1 - 1 / abs(a) ** 3)
    # the float agrees with the brute-force oracle (dynamic programming over covered phases)
    (block,) = fmo_blocks(load_request(json.dumps({"system": {"A": A, "C": [[1, 0]]}, "channel": _bern(lam)})).system)
    channel = load_request(json.dumps({"system": {"A": [[2]], "C": [[1]]}, "channel": _bern(lam)})).channel
    assert b.sigma == pytest.approx(oracle_sigma(block.phase, [channel]), rel=1e-9)


def test_radical_critical_probability():
    # eigenvalues 1 +- i (ratio i, period 4), one row: sigma = (1 - lambda)^(3/4) and
    # 2 (1 - lambda_c)^(3/4) = 1, i.e. lambda_c = 1 - 2^(-4/3): irrational, minimal polynomial
    # (1 - x)^3 - 1/16
    r = _run([[1, -1], [1, 1]], [[1, 0]], F(9, 10))
    expected = 1 - sympy.Rational(2) ** sympy.Rational(-4, 3)
    assert _same_algebraic(r.critical_arrival_probability_exact, expected)
    assert r.critical_arrival_probability == pytest.approx(float(sympy.N(expected, 30)), rel=1e-15)


# -- the radical type itself ------------------------------------------------------------


@pytest.mark.parametrize("seed", range(20))
def test_real_radical_against_sympy(seed: int):
    rng = random.Random(300 + seed)
    base = F(rng.randrange(1, 10**12), rng.randrange(1, 10**12))
    if seed % 3 == 0:  # a perfect power in disguise
        base = base ** rng.choice((2, 3, 6))
    e = F(rng.randrange(-12, 13) or 1, rng.randrange(1, 13))
    r = RealRadical.power(base, e)
    expected = sympy.Rational(base.numerator, base.denominator) ** sympy.Rational(e.numerator, e.denominator)
    assert _same_algebraic(r.text(), expected)
    # lowest terms: x^q - s is the minimal polynomial (Capelli), so the index is the degree
    assert sympy.degree(sympy.minimal_polynomial(expected, X), X) == r.index
    assert r.is_rational == expected.is_Rational


def test_real_radical_exact_comparison():
    a = RealRadical.power(F(2), F(1, 3))
    b = RealRadical.power(F(3), F(1, 4))
    assert a.compare(b) == (1 if 2**4 > 3**3 else -1)
    assert a.compare(RealRadical.power(F(4), F(1, 6))) == 0
