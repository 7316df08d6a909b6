"""Certified enclosures of algebraic numbers with python-flint (Arb balls).

Every eigenvalue is a root of an integer polynomial; flint's
``fmpz_poly.complex_roots`` returns disjoint isolating balls that are
*certified* to contain exactly one root each (Johansson, "Arb: efficient
arbitrary-precision midpoint-radius interval arithmetic", 2017).  Real roots
come first, in ascending order, with an imaginary part that is exactly zero,
so "this root is real" is decided, not guessed.  Decisions built on balls are
exact: a ball that excludes zero proves a non-zero number; a ball that
contains zero proves nothing, and the caller refines or falls back to exact
algebra.

Working precision is local (:func:`precision`), never left changed.
"""

from __future__ import annotations

import math
from contextlib import contextmanager
from fractions import Fraction
from functools import lru_cache
from typing import Any, Iterator, Sequence

from flint import acb, arb, ctx, fmpq, fmpz_poly

#: Starting working precision (bits) of root isolation.
START_PREC = 256
#: Largest working precision (bits) before a decision is given up as uncertifiable.
MAX_PREC = 1 << 15

IntCoeffs = tuple[int, ...]  # integer coefficients, lowest degree first


@contextmanager
def precision(bits: int) -> Iterator[None]:
    """Run the body at ``bits`` of working precision (flint's context), then restore it."""
    old = ctx.prec
    ctx.prec = bits
    try:
        yield
    finally:
        ctx.prec = old


def integer_coeffs(coeffs_high_first: Sequence[Any]) -> IntCoeffs:
    """Primitive integer multiple of a rational polynomial, lowest degree first.

    Accepts any rationals with ``numerator``/``denominator`` (SymPy ``QQ``,
    flint ``fmpq``, :class:`fractions.Fraction`); never converts through text.
    """
    fr = [Fraction(int(c.numerator), int(c.denominator)) for c in coeffs_high_first]
    den = 1
    for c in fr:
        den = den * c.denominator // math.gcd(den, c.denominator)
    ints = [int(c * den) for c in fr]
    g = 0
    for k in ints:
        g = math.gcd(g, k)
    g = g or 1
    if ints and ints[0] < 0:
        g = -g
    return tuple(k // g for k in reversed(ints))


@lru_cache(maxsize=512)
def _isolate(coeffs: IntCoeffs, prec: int) -> tuple[tuple[acb, ...], int]:
    with precision(prec):
        roots: list[Any] = fmpz_poly(list(coeffs)).complex_roots()
    balls: tuple[acb, ...] = tuple(pair[0] for pair in roots)
    n_real = sum(1 for r in balls if r.imag.is_exact() and r.imag.is_zero())
    return balls, n_real


def root_balls(coeffs: IntCoeffs, prec: int = START_PREC) -> tuple[tuple[acb, ...], int]:
    """Isolating balls of the roots of a square-free integer polynomial, and the number of real ones.

    The first ``n_real`` balls are the real roots in ascending order
    (imaginary part exactly zero); the others are non-real, conjugate pairs
    adjacent.  Each ball's radius is below ``2^-prec`` relative to its
    midpoint (flint's target accuracy).
    """
    return _isolate(coeffs, prec)


def ordered_roots(coeffs: IntCoeffs, prec: int = START_PREC) -> tuple[tuple[acb, ...], int]:
    """:func:`root_balls` in a deterministic order: real roots ascending, then by real part, imaginary part.

    The order of the non-real roots follows the midpoints; it only labels the
    roots (no decision depends on it), and stays the same at any precision as
    long as the midpoints are separated, which the isolation guarantees.
    """
    balls, n_real = root_balls(coeffs, prec)
    rest = sorted(balls[n_real:], key=lambda z: (z.real.mid(), z.imag.mid()))
    return balls[:n_real] + tuple(rest), n_real


def refine_root(coeffs: IntCoeffs, index: int, prec: int) -> acb:
    """Root ``index`` of :func:`ordered_roots` (at :data:`START_PREC`) enclosed at ``prec`` bits.

    The labelled ball is disjoint from every other root's ball, so the one
    ball at ``prec`` that overlaps it encloses the same root.

    Raises
    ------
    NumericalFailure
        If the match is not unique (it always is for isolating balls).
    """
    if prec <= START_PREC:
        return ordered_roots(coeffs)[0][index]
    label = ordered_roots(coeffs)[0][index]
    fine, _ = root_balls(coeffs, prec)
    hits = [z for z in fine if z.overlaps(label)]
    if len(hits) != 1:
        from ..errors import NumericalFailure

        raise NumericalFailure("a refined root enclosure matches no unique root")
    return hits[0]


def rational_ball(q: Fraction) -> arb:
    """The exact rational ``q`` as a ball (exact when representable, else a tight enclosure)."""
    return arb(fmpq(q.numerator, q.denominator))


def sign(x: arb) -> int | None:
    """Sign of the real number in ``x`` if the ball proves it (``0`` only for the exact zero ball)."""
    if x.is_exact() and x.is_zero():
        return 0
    if x > 0:
        return 1
    if x < 0:
        return -1
    return None


def to_float(x: arb) -> float:
    """Midpoint of a ball as a float (``inf`` on overflow, never an exception)."""
    try:
        return float(x.mid())
    except OverflowError:  # pragma: no cover - flint saturates instead
        return math.inf if x > 0 else -math.inf


def horner(coeffs_low_first: Sequence[Fraction], z: acb) -> acb:
    """``sum_j c_j z^j`` for exact rational ``c_j`` at a ball ``z`` (current precision)."""
    acc = acb(0)
    for c in reversed(coeffs_low_first):
        acc = acc * z + arb(fmpq(c.numerator, c.denominator))
    return acc
