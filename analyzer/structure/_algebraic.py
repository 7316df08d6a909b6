"""Real algebraic numbers for exact comparisons at the edge of the verdict.

Only what Theorem 1 needs: ``beta = |alpha|^2`` of an FMO block as the root of
an irreducible polynomial over ``Q``, and the sign of ``beta^N - c`` for a
rational ``c``.  Equality is decided exactly (``h`` irreducible, so
``beta^N = c`` iff ``h`` divides ``x^N - c``); a strict inequality is decided
by certified root refinement, which terminates because the difference is a
non-zero algebraic number.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import mpmath
from sympy import QQ, CRootOf, Poly, Rational

from ._eigen import DIGITS, X


def power_minus(N: int, c: Any) -> Poly:
    """``x**N - c`` over ``QQ``, built from its coefficients.

    Building it as the expression ``X**N - c`` costs the first call about
    0.1 s of SymPy sub-imports (combinatorics, tensor); the coefficient list
    does not.

    Examples
    --------
    >>> power_minus(3, QQ(1, 2)).all_coeffs()
    [1, 0, 0, -1/2]
    """
    coeffs = [QQ(1)] + [QQ(0)] * (N - 1) + [-QQ(c)] if N > 0 else [QQ(1) - QQ(c)]
    return Poly.from_list(coeffs, X, domain=QQ)


@dataclass(frozen=True)
class AlgebraicReal:
    """A positive real algebraic number: ``CRootOf(minpoly, index)`` or a rational."""

    rational: Fraction | None = None
    minpoly: Poly | None = None
    index: int = 0

    @classmethod
    def of_rational(cls, x: Fraction) -> AlgebraicReal:
        return cls(rational=x)

    @property
    def is_rational(self) -> bool:
        return self.rational is not None

    def expr(self) -> Any:
        """Exact SymPy expression."""
        if self.rational is not None:
            return Rational(self.rational.numerator, self.rational.denominator)
        return CRootOf(self.minpoly, self.index)

    def text(self) -> str:
        """Exact text: ``"25/16"`` or ``"CRootOf(x**2 - 3*x + 1, 1)"``."""
        if self.rational is not None:
            r = self.rational
            return str(r.numerator) if r.denominator == 1 else f"{r.numerator}/{r.denominator}"
        return str(self.expr())

    def approx(self, digits: int = DIGITS) -> mpmath.mpf:
        if self.rational is not None:
            with mpmath.workdps(digits + 10):
                return mpmath.mpf(self.rational.numerator) / self.rational.denominator
        with mpmath.workdps(digits + 10):
            return mpmath.mpf(str(CRootOf(self.minpoly, self.index).evalf(digits)))

    def __float__(self) -> float:
        return float(self.approx(20))

    def compare_power(self, N: int, c: Fraction) -> int:
        """Sign of ``self**N - c`` (exact)."""
        if self.rational is not None:
            v = self.rational**N - c
            return (v > 0) - (v < 0)
        assert self.minpoly is not None
        target = power_minus(N, QQ(c.numerator, c.denominator))
        if target.rem(self.minpoly).is_zero:
            return 0
        digits = 30
        while True:
            with mpmath.workdps(digits + 10):
                v = self.approx(digits) ** N - mpmath.mpf(c.numerator) / c.denominator
                scale = max(mpmath.mpf(1), abs(mpmath.mpf(c.numerator) / c.denominator))
                if abs(v) > scale * mpmath.mpf(10) ** (-(digits - 5)) * N:
                    return 1 if v > 0 else -1
            digits *= 2
            if digits > 4000:  # pragma: no cover - would need a pathological input
                raise ArithmeticError("could not separate an algebraic number from a rational")


def real_root_matching(h: Poly, value: mpmath.mpf) -> int | None:
    """Index of the real root of ``h`` equal to ``value`` (numerically), if any."""
    best = None
    with mpmath.workdps(DIGITS + 10):
        for i in range(h.count_roots()):
            r = mpmath.mpf(str(CRootOf(h, i).evalf(DIGITS)))
            if abs(r - value) <= mpmath.mpf(10) ** (-(DIGITS // 2)) * max(1, abs(value)):
                if best is not None:  # pragma: no cover - roots are separated far beyond this
                    raise ArithmeticError("two real roots agree to 30 digits")
                best = i
    return best
