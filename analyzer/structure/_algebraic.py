"""Real algebraic numbers for exact comparisons at the edge of the verdict.

Only what Theorem 1 needs: ``beta = |alpha|^2`` of an FMO block as the root of
an irreducible polynomial over ``Q``, and the sign of ``beta^N - c`` for a
rational ``c``.  Equality is decided exactly (``h`` irreducible, so
``beta^N = c`` iff ``h`` divides ``x^N - c``); a strict inequality is decided
by certified root enclosures (flint, Arb balls), refined until the sign of
the non-zero difference is proved.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import mpmath
from flint import arb
from sympy import QQ, CRootOf, Poly, Rational

from ..errors import NumericalFailure
from ._balls import MAX_PREC, START_PREC, integer_coeffs, precision, rational_ball, root_balls, sign
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

    def writable(self) -> bool:
        """Whether :meth:`text` fits Python's int-to-text limit (4300 digits per integer)."""
        if self.rational is not None:
            return max(self.rational.numerator.bit_length(), self.rational.denominator.bit_length()) < 12000
        assert self.minpoly is not None
        return all(
            max(int(c.numerator).bit_length(), int(c.denominator).bit_length()) < 12000
            for c in self.minpoly.all_coeffs()
        )

    def text(self) -> str:
        """Exact text: ``"25/16"`` or ``"CRootOf(x**2 - 3*x + 1, 1)"``."""
        if self.rational is not None:
            r = self.rational
            return str(r.numerator) if r.denominator == 1 else f"{r.numerator}/{r.denominator}"
        return str(self.expr())

    def ball(self, prec: int = START_PREC) -> arb:
        """Certified enclosure at ``prec`` bits (flint root isolation of :attr:`minpoly`)."""
        if self.rational is not None:
            with precision(prec):
                return rational_ball(self.rational)
        assert self.minpoly is not None
        coeffs = integer_coeffs(self.minpoly.all_coeffs())
        balls, n_real = root_balls(coeffs, prec)
        if self.index >= n_real:  # pragma: no cover - constructed from a real root
            raise NumericalFailure("an algebraic real refers to a non-real root")
        return balls[self.index].real

    def approx(self, digits: int = DIGITS) -> mpmath.mpf:
        """Midpoint of :meth:`ball` at ``digits`` decimal digits, as an mpmath number."""
        bits = max(START_PREC, int(digits * 3.33) + 16)
        mid = self.ball(bits).mid()
        man, exp = mid.man_exp()
        with mpmath.workdps(digits + 10):
            return mpmath.mpf((int(man), int(exp)))

    def __float__(self) -> float:
        return float(self.approx(20))

    def compare_power(self, N: int, c: Fraction) -> int:
        """Sign of ``self**N - c`` (exact).

        Equality is exact (the minimal polynomial divides ``x^N - c``);
        otherwise the difference is a non-zero algebraic number and the
        enclosure is refined until its sign is proved.
        """
        if self.rational is not None:
            v = self.rational**N - c
            return (v > 0) - (v < 0)
        assert self.minpoly is not None
        target = power_minus(N, QQ(c.numerator, c.denominator))
        if target.rem(self.minpoly).is_zero:
            return 0
        prec = START_PREC
        while prec <= MAX_PREC:
            with precision(prec):
                s = sign(self.ball(prec) ** N - rational_ball(c))
            if s is not None and s != 0:
                return s
            prec *= 2
        raise NumericalFailure("could not separate an algebraic number from a rational")  # pragma: no cover
