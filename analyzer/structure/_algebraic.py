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
from functools import cached_property
from typing import Any

import mpmath
from flint import arb, fmpq, fmpq_mat, fmpz_poly
from sympy import QQ, CRootOf, Poly, Rational

from ..errors import NumericalFailure
from ._balls import MAX_PREC, START_PREC, IntCoeffs, integer_coeffs, precision, rational_ball, root_balls, sign
from ._eigen import DIGITS, X
from ._texts import crootof_text

#: Largest ``deg h * |a|`` and ``deg h * b`` for which :meth:`AlgebraicReal.power_degree` factors
#: (``g(x^b)`` of degree 3800 took 15 s; degree 256 takes milliseconds).
MAX_POWER_DEGREE_WORK = 256


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
        """Exact text: ``"25/16"`` or ``"CRootOf(x**2 - 3*x + 1, 1)"`` (SymPy's text of :meth:`expr`)."""
        if self.rational is not None:
            r = self.rational
            return str(r.numerator) if r.denominator == 1 else f"{r.numerator}/{r.denominator}"
        return self.root_text() or str(self.expr())

    @cached_property
    def int_coeffs(self) -> IntCoeffs:
        """The primitive integer multiple of :attr:`minpoly`, lowest degree first."""
        assert self.minpoly is not None
        return integer_coeffs(self.minpoly.all_coeffs())

    def root_text(self) -> str | None:
        """``str(CRootOf(minpoly, index))`` written without SymPy, or ``None`` where SymPy rescales the root.

        See :func:`kfio.structure._texts.crootof_text`; ``None`` for a rational.
        """
        if self.rational is not None:
            return None
        return crootof_text(self.int_coeffs, self.index)

    def ball(self, prec: int = START_PREC) -> arb:
        """Certified enclosure at ``prec`` bits (flint root isolation of :attr:`minpoly`)."""
        if self.rational is not None:
            with precision(prec):
                return rational_ball(self.rational)
        assert self.minpoly is not None
        balls, n_real = root_balls(self.int_coeffs, prec)
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

    def power_ball(self, e: Fraction, prec: int = START_PREC) -> arb:
        """Certified enclosure of ``self^e`` (the positive real power) at ``prec`` bits: ``(self^a)^(1/b)``."""
        with precision(prec):
            x = self.ball(prec) ** e.numerator
            return x if e.denominator == 1 else x.root(e.denominator)

    def power_degree(self, e: Fraction) -> int | None:
        """Degree over ``Q`` of ``gamma = self^e`` (``e = a/b``), from FLINT factorizations.

        ``self^a`` is a root of ``charpoly(C_h^a)`` (``C_h`` the companion
        matrix of the minimal polynomial ``h``: its eigenvalues are the
        ``a``-th powers of the roots of ``h``); its minimal polynomial ``g`` is
        the irreducible factor vanishing on the certified enclosure of
        ``self^a``.  ``gamma`` is a root of ``g(x^b)``, and its minimal
        polynomial is the factor of ``g(x^b)`` vanishing on the enclosure of
        ``gamma`` (distinct irreducible factors share no root, so refining the
        enclosure singles it out).  ``None`` for a rational or when no factor
        is singled out by :data:`MAX_PREC`, and when ``d |a|`` or ``d b`` exceeds
        :data:`MAX_POWER_DEGREE_WORK` (``d = deg h``).  Only short display texts use it
        (:func:`kfio.structure._display.short_text`).
        """
        if self.rational is not None:
            return None
        h = self.int_coeffs
        d = len(h) - 1
        a, b = e.numerator, e.denominator
        if abs(a) == 1 and b == 1:  # 1/beta has the reversed minimal polynomial
            return d
        if d * abs(a) > MAX_POWER_DEGREE_WORK or d * b > MAX_POWER_DEGREE_WORK:
            return None  # the display says "algebraic number": factoring g(x^b) of degree d b could take minutes
        C = fmpq_mat(d, d)
        for i in range(1, d):
            C[i, i - 1] = 1
        for i in range(d):
            C[i, d - 1] = fmpq(-h[i], h[d])
        M = _matrix_power(C.inv() if a < 0 else C, abs(a))
        g = _vanishing_factor(_integer_factors(M.charpoly()), lambda prec: self.ball(prec) ** a)
        if g is None or b == 1:
            return None if g is None else len(g) - 1
        spread = [0] * ((len(g) - 1) * b + 1)
        for i, c in enumerate(g):
            spread[i * b] = c
        gamma = _vanishing_factor(_integer_factors(fmpz_poly(spread)), lambda prec: self.power_ball(e, prec))
        return None if gamma is None else len(gamma) - 1

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


def _matrix_power(M: fmpq_mat, k: int) -> fmpq_mat:
    """``M^k`` for ``k >= 0`` by repeated squaring."""
    result = fmpq_mat(M.nrows(), M.ncols())
    for i in range(M.nrows()):
        result[i, i] = 1
    while k:
        if k & 1:
            result = result * M
        k >>= 1
        if k:
            M = M * M
    return result


def _integer_factors(P: Any) -> list[IntCoeffs]:
    """Irreducible factors over ``Q`` of a FLINT polynomial, as primitive integer coefficients, lowest first."""
    _, factors = P.factor()
    return [integer_coeffs([c for c in reversed(f.coeffs())]) for f, _ in factors]


def _vanishing_factor(factors: list[IntCoeffs], enclosure: Any) -> IntCoeffs | None:
    """The one factor whose value on ``enclosure(prec)`` contains 0, refining ``prec`` until it is unique."""
    if len(factors) == 1:
        return factors[0]
    prec = START_PREC
    while prec <= MAX_PREC:
        with precision(prec):
            z = enclosure(prec)
            hits = [f for f in factors if fmpz_poly(list(f))(z).contains(0)]
        if len(hits) == 1:
            return hits[0]
        prec *= 2
    return None
