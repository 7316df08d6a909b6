"""Real radicals ``s**(1/q)`` of positive rationals, in exact arithmetic only.

Theorem 1 of Rohr, Marelli and Fu (2014) with Bernoulli channels gives
closed forms whose values are radicals of rationals: ``sigma_k^N`` is the
rational ``c = prod_g (1 - lambda_g)^{z_g}`` (Corollary 2), so ``sigma_k =
c^(1/N)``, and for a rational ``beta = |alpha_k|^2`` the critical arrival
probability is ``1 - beta^(-N/z)``.  Both are built here from integers, never
recognised from floats (no PSLQ, no ``nsimplify``).

A radical is kept in lowest terms: ``x = s^(1/q)`` with ``s > 0`` rational
and ``s`` not a ``p``-th power in ``Q`` for any prime ``p | q``.  By Capelli's
theorem (``x^q - s`` is irreducible over ``Q`` iff ``s`` is not a ``p``-th
power for a prime ``p | q`` and, when ``4 | q``, not of the form ``-4 b^4``,
which a positive ``s`` never is) ``x^q - s`` is then the minimal polynomial of
``x``, and ``x`` is rational exactly when ``q = 1``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Iterable

import mpmath
from sympy import Rational, integer_nthroot, primefactors

from ..errors import NumericalFailure


def _rational_root(s: Fraction, p: int) -> Fraction | None:
    """``s^(1/p)`` if it is rational (``s > 0``), else ``None``."""
    num, ok = integer_nthroot(s.numerator, p)
    if not ok:
        return None
    den, ok = integer_nthroot(s.denominator, p)
    return Fraction(int(num), int(den)) if ok else None


@dataclass(frozen=True, order=False)
class RealRadical:
    """The positive real ``base**(1/index)``, in lowest terms (see the module docstring).

    Examples
    --------
    >>> RealRadical.of(Fraction(9, 4), 2).text()
    '3/2'
    >>> RealRadical.of(Fraction(8), 6).text()
    'sqrt(2)'
    >>> RealRadical.power(Fraction(1, 2), Fraction(2, 3)).text()
    '2**(1/3)/2'
    """

    base: Fraction
    index: int

    @classmethod
    def of(cls, base: Fraction, index: int) -> RealRadical:
        """``base^(1/index)`` reduced: a prime ``p | index`` with ``base`` a ``p``-th power is divided out."""
        if base <= 0 or index < 1:
            raise NumericalFailure("a real radical needs a positive base and a positive index")
        changed = True
        while changed and index > 1:
            changed = False
            for p in primefactors(index):
                root = _rational_root(base, p)
                if root is not None:
                    base, index, changed = root, index // p, True
                    break
        return cls(base, index)

    @classmethod
    def power(cls, base: Fraction, exponent: Fraction) -> RealRadical:
        """``base^exponent`` for a rational ``base > 0`` and a rational exponent."""
        return cls.product([(base, exponent)])

    @classmethod
    def product(cls, factors: Iterable[tuple[Fraction, Fraction]]) -> RealRadical:
        """``prod_i b_i^(e_i)`` for rationals ``b_i > 0``: ``(prod_i b_i^(e_i q))^(1/q)``, ``q = lcm den(e_i)``."""
        factors = list(factors)
        q = math.lcm(1, *(Fraction(e).denominator for _, e in factors))
        s = Fraction(1)
        for b, e in factors:
            k = Fraction(e) * q
            s *= Fraction(b) ** int(k)
        return cls.of(s, q)

    @property
    def is_rational(self) -> bool:
        return self.index == 1

    def compare(self, other: RealRadical) -> int:
        """Sign of ``self - other``, exactly: compare ``self^L`` with ``other^L``, ``L = lcm`` of the indices."""
        L = math.lcm(self.index, other.index)
        a = self.base ** (L // self.index)
        b = other.base ** (L // other.index)
        return (a > b) - (a < b)

    def approx(self, digits: int = 30) -> mpmath.mpf:
        """The value to ``digits`` significant digits."""
        with mpmath.workdps(digits + 10):
            return mpmath.root(mpmath.mpf(self.base.numerator) / self.base.denominator, self.index)

    def expr(self) -> Any:
        """The exact SymPy number (SymPy's automatic simplification of ``Rational**Rational`` is exact)."""
        return Rational(self.base.numerator, self.base.denominator) ** Rational(1, self.index)

    def text(self) -> str:
        """Exact text: ``"3/2"``, ``"sqrt(2)"``, ``"2**(2/3)/4"`` (SymPy's printing of :meth:`expr`)."""
        b = self.base
        if self.index == 1:
            return str(b.numerator) if b.denominator == 1 else f"{b.numerator}/{b.denominator}"
        return str(self.expr())

    def one_minus_text(self) -> str:
        """Exact text of ``1 - self``: a rational, or ``"1 - 2**(2/3)/4"``."""
        if self.index == 1:
            v = 1 - self.base
            return str(v.numerator) if v.denominator == 1 else f"{v.numerator}/{v.denominator}"
        return str(1 - self.expr())


__all__ = ["RealRadical"]
