"""Exact texts of rational and quadratic roots of integer polynomials (no SymPy: the report stays fast)."""

from __future__ import annotations

import math
from fractions import Fraction

import flint

#: Coefficients longer than this (about 200 decimal digits) give no exact text.
MAX_TEXT_BITS = 664


def _fraction_text(x: Fraction) -> str:
    return str(x.numerator) if x.denominator == 1 else f"{x.numerator}/{x.denominator}"


def _square_part(d: int, trial: int = 1000) -> tuple[int, int]:
    """``d = k^2 e`` with the square factors of ``d`` below ``trial`` moved into ``k``."""
    k = 1
    for p in range(2, trial):
        while d % (p * p) == 0:
            d //= p * p
            k *= p
    r = math.isqrt(d)
    if r * r == d:
        return k * r, 1
    return k, d


def root_text(f: flint.fmpz_poly | None, near: float) -> str | None:
    """The root of ``f`` (degree 1 or 2, integer coefficients) nearest ``near``, exactly; ``None`` otherwise.

    ``None`` also when a coefficient has more than :data:`MAX_TEXT_BITS` bits: such a text has hundreds
    of digits, past what a report shows (the minimal polynomial and an enclosure describe the root).

    A quadratic ``a x^2 + b x + c`` has roots ``(-b +- sqrt(b^2 - 4 a c)) / (2 a)``.

    Examples
    --------
    >>> root_text(flint.fmpz_poly([-9, 25]), 0.36), root_text(flint.fmpz_poly([-2, 0, 1]), 1.4)
    ('9/25', 'sqrt(2)')
    """
    if f is None:
        return None
    c = [int(x) for x in f.coeffs()]
    if any(x.bit_length() > MAX_TEXT_BITS for x in c):
        return None  # the text would pass the report's cap of 200 digits
    if len(c) == 2:
        return _fraction_text(Fraction(-c[0], c[1]))
    if len(c) != 3:
        return None
    cc, b, a = c
    disc = b * b - 4 * a * cc
    if disc < 0:
        return None
    k, e = _square_part(disc)
    if e == 1:
        roots = [Fraction(-b + s * k, 2 * a) for s in (1, -1)]
        return _fraction_text(min(roots, key=lambda r: abs(float(r) - near)))
    sign = 1 if abs((-b + k * math.sqrt(e)) / (2 * a) - near) <= abs((-b - k * math.sqrt(e)) / (2 * a) - near) else -1
    g = math.gcd(math.gcd(b, k), 2 * a)
    b2, k2, den = -b // g, sign * k // g, 2 * a // g
    if den < 0:
        b2, k2, den = -b2, -k2, -den
    rad = f"sqrt({e})" if abs(k2) == 1 else f"{abs(k2)}*sqrt({e})"
    body = rad if b2 == 0 else f"{b2} {'+' if k2 > 0 else '-'} {rad}"
    if b2 == 0 and k2 < 0:
        body = f"-{rad}"
    return body if den == 1 else f"({body})/{den}"


__all__ = ["root_text"]
