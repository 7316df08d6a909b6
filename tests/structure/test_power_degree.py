"""Degree over Q of ``beta^e`` from FLINT (summaries' short texts) against SymPy's minimal polynomial."""

from __future__ import annotations

from fractions import Fraction

import pytest
import sympy
from sympy import QQ, CRootOf, Poly, Rational

from kfio.structure._algebraic import MAX_POWER_DEGREE_WORK, AlgebraicReal
from kfio.structure._eigen import X


def _beta(coeffs_high_first: list[int], index: int) -> AlgebraicReal:
    return AlgebraicReal(minpoly=Poly([QQ(c) for c in coeffs_high_first], X, domain=QQ).monic(), index=index)


@pytest.mark.parametrize(
    "coeffs, index, exponent",
    [
        ([1, 0, -3, -1], 2, Fraction(-1)),
        ([1, 0, -3, -1], 2, Fraction(-2)),
        ([1, 0, -3, -1], 2, Fraction(-3, 2)),
        ([1, 0, -3, -1], 2, Fraction(-2, 3)),
        ([1, 0, 0, 0, -2], 1, Fraction(-2)),  # 2^(1/4): its square has degree 2, its fourth power 1
        ([1, 0, 0, 0, -2], 1, Fraction(-4)),
        ([1, 0, 0, 0, -2], 1, Fraction(-1, 2)),
        ([1, 0, 0, 0, -2], 1, Fraction(-4, 3)),
        ([3, -7, 0, 5], 0, Fraction(-5, 4)),
    ],
)
def test_power_degree_is_the_degree_of_sympys_minimal_polynomial(coeffs, index, exponent) -> None:
    beta = _beta(coeffs, index)
    if not beta.expr().is_positive:
        beta = _beta(coeffs, index + 1)
    e = Rational(exponent.numerator, exponent.denominator)
    expected = sympy.minimal_polynomial(1 - CRootOf(beta.minpoly, beta.index) ** e, X, polys=True).degree()
    assert beta.power_degree(exponent) == expected


def test_power_degree_gives_up_beyond_its_work_allowance() -> None:
    beta = _beta([1, 0, -3, -1], 2)
    b = MAX_POWER_DEGREE_WORK // 3 + 1  # g(x^b) of degree 3 b > the allowance
    assert beta.power_degree(Fraction(-1, b)) is None
    assert beta.power_degree(Fraction(-1, b - 1)) == 3 * (b - 1)  # within it: beta^(-1/k) has degree 3k here
    assert _beta([1, 0, -3, -1], 2).power_degree(Fraction(-1)) == 3
    assert AlgebraicReal.of_rational(Fraction(4)).power_degree(Fraction(-1, 2)) is None
