"""Ranks over a number field from below, modulo a prime of degree one: full rank certified in microseconds.

Let ``Q(theta)`` have the monic minimal polynomial ``m`` and let ``p`` be a
prime with ``m`` ``p``-integral and a root ``r`` of ``m`` modulo ``p``.  Then
``theta -> r`` extends to a ring homomorphism from the elements whose
coefficients (in the basis ``1, theta, ..., theta^(d-1)``) have no ``p`` in
their denominators onto ``F_p``.  A minor that is non-zero modulo ``p`` is
non-zero, so the rank modulo ``p`` never exceeds the true rank, and a matrix
of full column rank modulo ``p`` has full column rank.  That is the common
question of the exact confirmations (a one-slot extension of a maximal
blind set has rank ``L``); a rank below full modulo ``p`` proves nothing
and the caller falls back to exact arithmetic over ``Q(theta)``.
"""

from __future__ import annotations

from typing import Any, Sequence

import flint
from sympy import QQ

#: Primes are tried downwards from here (word-sized, so ``nmod_mat`` works in machine words).
_START = 2**61

#: Primes tried before giving up (a root exists for a positive density of primes).
_TRIES = 40


def _prime_below(n: int) -> int:
    """The largest prime below ``n`` (FLINT's deterministic test; SymPy's sieve costs 0.1 s to set up)."""
    p = n - 1 if n % 2 == 0 else n - 2
    while not flint.fmpz(p).is_prime():
        p -= 2
    return p


class ModP:
    """Reduction of ``Q(theta)`` (or ``Q``) modulo a prime with a root of the minimal polynomial."""

    def __init__(self, p: int, root: int) -> None:
        self.p = p
        self.root = root

    @classmethod
    def for_field(cls, K: Any) -> ModP | None:
        """A reduction for the SymPy field ``K`` (``QQ`` or an algebraic field), or ``None`` if none was found."""
        if K == QQ:
            return cls(_prime_below(_START), 0)
        try:
            modulus = [QQ(c) for c in K.mod.to_list()]
        except (AttributeError, TypeError):
            return None
        p = _START
        for _ in range(_TRIES):
            p = _prime_below(p)
            if any(int(c.denominator) % p == 0 for c in modulus):
                continue
            coeffs = [int(c.numerator) * pow(int(c.denominator), -1, p) % p for c in reversed(modulus)]
            roots = flint.nmod_poly(coeffs, p).roots()
            if roots:
                return cls(p, int(roots[0][0]))
        return None

    def reduce(self, coefficients: Sequence[Any]) -> int | None:
        """The image of ``sum c_i theta^(d-1-i)`` (coefficients highest first), ``None`` if a denominator has ``p``."""
        p, acc = self.p, 0
        for c in coefficients:
            q = QQ(c)
            den = int(q.denominator) % p
            if den == 0:
                return None
            acc = (acc * self.root + int(q.numerator) * pow(den, -1, p)) % p
        return acc

    def element(self, a: Any) -> int | None:
        """The image of an element of the field (an ``ANP`` or a rational)."""
        to_list = getattr(a, "to_list", None)
        return self.reduce(to_list() if to_list is not None else [a])

    def matrix(self, rows: Sequence[Sequence[Any]]) -> list[list[int]] | None:
        """The images of a matrix of field elements, ``None`` if an entry does not reduce."""
        out = []
        for row in rows:
            images = [self.element(a) for a in row]
            if any(x is None for x in images):
                return None
            out.append([int(x) for x in images if x is not None])
        return out

    def rank(self, rows: Sequence[Sequence[int]], n_columns: int) -> int:
        """Rank of reduced rows over ``F_p`` (at most the rank over the field)."""
        if not rows:
            return 0
        flat = [x for row in rows for x in row]
        return int(flint.nmod_mat(len(rows), n_columns, flat, self.p).rank())
