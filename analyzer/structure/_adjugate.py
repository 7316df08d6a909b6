"""Eigenvectors of a simple eigenvalue over ``Q``, with no number-field arithmetic.

Let ``f`` be an irreducible factor of multiplicity one of ``p = det(x I - A)``
and ``g = p / f``.  By Cayley-Hamilton ``f(A) g(A) = 0``, so ``w = g(A) u``
lies in ``ker f(A)`` for every rational ``u``, and ``w != 0`` for some unit
vector ``u``.  The quotient ``f(x) / (x - theta)`` (``theta`` a root of ``f``)
applied to ``w`` kills every component of ``w`` except the one along the
eigenvector of ``theta``, so

    v(theta) = sum_{j < d} theta^j b_j,   b_{d-1} = w,   b_{j-1} = A b_j + c_j w

(``f = sum_j c_j x^j`` monic of degree ``d``) is an eigenvector:
``(A - theta I) v(theta) = -(f(A) w) = 0``.  It is non-zero, since the
components of a rational ``w`` along the eigenvectors of the roots of ``f``
are Galois conjugates of each other, so none of them vanishes.  The same
rational ``b_j`` give the eigenvector of every root of ``f``.  This is a
column of the adjugate of ``theta I - A`` up to a factor, written over ``Q``
(Rohr, Marelli and Fu, 2014, Section III, need only these eigenvectors).

All arithmetic is exact, in flint's ``fmpq_mat``.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any, Callable, Sequence

from flint import fmpq, fmpq_mat, fmpq_poly

from ..errors import NumericalFailure


def to_fmpq_mat(rows: Sequence[Sequence[Any]]) -> fmpq_mat:
    """An exact rational matrix (entries with ``numerator``/``denominator``) as ``fmpq_mat``."""
    n, m = len(rows), len(rows[0]) if rows else 0
    return fmpq_mat(n, m, [fmpq(int(x.numerator), int(x.denominator)) for row in rows for x in row])


def _poly_times_vector(coeffs_low_first: Sequence[fmpq], A: fmpq_mat, u: fmpq_mat) -> fmpq_mat:
    """``q(A) u`` by Horner's rule with matrix-vector products."""
    acc = u * 0
    for c in reversed(coeffs_low_first):
        acc = A * acc + u * c
    return acc


def simple_eigenvector(
    A: fmpq_mat, charpoly: fmpq_poly, f: fmpq_poly, tick: Callable[[], None] | None = None
) -> list[list[Fraction]]:
    """Rational ``b_0, ..., b_{d-1}`` with ``v(theta) = sum_j theta^j b_j`` an eigenvector of every root of ``f``.

    Parameters
    ----------
    A:
        The ``n x n`` rational matrix.
    charpoly:
        ``det(x I - A)``.
    f:
        A monic irreducible factor of ``charpoly`` of multiplicity one.

    Returns
    -------
    list of list of Fraction
        ``n`` rows, each the ``d`` coefficients (lowest power of ``theta``
        first) of one component of ``v``.

    Raises
    ------
    NumericalFailure
        If ``f`` is not a simple factor (no non-zero ``w`` exists).
    """
    n = A.nrows()
    g, r = divmod(charpoly, f)
    if not r.is_zero():
        raise NumericalFailure("the factor does not divide the characteristic polynomial")
    gc = g.coeffs()
    fc = f.coeffs()
    d = f.degree()
    for i in range(n):
        if tick is not None:
            tick()
        u = fmpq_mat(n, 1, [1 if k == i else 0 for k in range(n)])
        w = _poly_times_vector(gc, A, u)
        if any(x != 0 for x in w.entries()):
            break
    else:
        raise NumericalFailure("g(A) vanishes: the factor is not simple")
    b = [w]
    for j in range(d - 1, 0, -1):
        b.append(A * b[-1] + w * fc[j])
    if any(x != 0 for x in (A * b[-1] + w * fc[0]).entries()):  # f(A) w, zero by Cayley-Hamilton
        raise NumericalFailure("f(A) w is not zero")  # pragma: no cover - algebraic identity
    b.reverse()  # b[j] multiplies theta^j
    cols = [bj.entries() for bj in b]
    return [[Fraction(int(cols[j][k].p), int(cols[j][k].q)) for j in range(d)] for k in range(n)]
