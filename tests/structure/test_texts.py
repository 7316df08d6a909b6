"""The exact texts built from coefficients are SymPy's printer output, character for character."""

from __future__ import annotations

import random
from fractions import Fraction

import pytest
import sympy
from sympy import QQ, CRootOf, Poly

from kfio.structure._balls import integer_coeffs
from kfio.structure._eigen import X
from kfio.structure._texts import crootof_text, poly_text


def _random_coeffs(rng: random.Random) -> list[Fraction]:
    d = rng.randint(0, 7)
    big = rng.choice([3, 20, 10**12])
    cs = [
        Fraction(rng.randint(-big, big), rng.choice([1, rng.randint(1, big)])) if rng.random() < 0.7 else Fraction(0)
        for _ in range(d + 1)
    ]
    if cs[0] == 0:
        cs[0] = Fraction(rng.choice([1, -1, 3, -7]), rng.choice([1, 7]))
    return cs


@pytest.mark.parametrize("seed", range(4))
def test_poly_text_is_sympys_text(seed: int) -> None:
    rng = random.Random(seed)
    for _ in range(300):
        cs = _random_coeffs(rng)
        expected = str(Poly([QQ(c.numerator, c.denominator) for c in cs], X, domain=QQ).as_expr())
        assert poly_text(cs) == expected, cs


@pytest.mark.parametrize(
    "cs", [[-1, 0, Fraction(1, 2)], [-2, 3], [Fraction(-1, 7), 0, 3], [1, -1], [-1, 0, 0, 1], [-1, 1, 1]]
)
def test_poly_text_keeps_sympys_constant_first_exception(cs) -> None:
    # SymPy prints c - a*x**k (constant first) for exactly a positive constant and one negative term
    assert poly_text(cs) == str(Poly([QQ(Fraction(c).numerator, Fraction(c).denominator) for c in cs], X).as_expr())


@pytest.mark.slow
def test_crootof_text_is_sympys_text() -> None:
    rng = random.Random(7)
    checked = rescaled = 0
    while checked < 60 or rescaled == 0:
        cs = _random_coeffs(rng)
        if rng.random() < 0.1:  # x^d + b^d c with a square-ish constant: SymPy pulls out b
            cs = (
                [Fraction(1)]
                + [Fraction(0)] * (len(cs) - 2)
                + [Fraction(rng.choice([4, 9, 25, 8]) * rng.choice([1, 3]))]
            )
        poly = Poly([QQ(c.numerator, c.denominator) for c in cs], X, domain=QQ)
        if poly.degree() < 2 or not poly.is_irreducible:
            continue
        monic = poly.monic()
        n_real = monic.count_roots()
        for index in {0, monic.degree() - 1, max(n_real - 1, 0)}:
            root = CRootOf(monic, index)
            text = crootof_text(integer_coeffs(monic.all_coeffs()), index)
            if not isinstance(root, CRootOf):  # SymPy rescaled the root, b*CRootOf(...): the caller prints it
                assert text is None, str(root)
                rescaled += 1
            if text is None:  # None is always allowed: the caller then asks SymPy
                continue
            assert text == str(root)
            for e in (sympy.Rational(1), sympy.Rational(3, 2), sympy.Rational(2)):
                one_minus = "1 - 1/" + (text if e == 1 else f"{text}**{e}" if e.q == 1 else f"{text}**({e})")
                if root.is_positive:
                    assert one_minus == str(1 - root ** (-e))
            checked += 1
    assert rescaled > 0  # the fallback was exercised
