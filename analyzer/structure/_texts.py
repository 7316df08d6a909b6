"""Exact texts of polynomials and their roots, written as SymPy prints them, without SymPy.

The JSON reports carry exact algebraic numbers as SymPy's text
(``"root of x**3 - 63*x**2/25 + ... near ..."``, ``"CRootOf(62500000000*x**3 - ..., 0)"``).
Printing goes through SymPy's expression trees, about 1 ms per polynomial, which
was the larger part of an uncached analysis of a small plant.  The texts
here are built from the coefficients directly; ``tests/structure/test_texts.py``
checks them against SymPy's printer character for character on random polynomials.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Sequence


def _monomial(k: int) -> str:
    return "" if k == 0 else ("x" if k == 1 else f"x**{k}")


def _term(c: Fraction, k: int) -> str:
    """One term ``c x^k`` (``c != 0``) as SymPy's ``StrPrinter`` writes a ``Mul``: ``-3*x**2/2``."""
    sign = "-" if c < 0 else ""
    p, q = abs(c.numerator), c.denominator
    mono = _monomial(k)
    if not mono:
        body = str(p) if q == 1 else f"{p}/{q}"
    else:
        body = mono if p == 1 else f"{p}*{mono}"
        if q != 1:
            body = f"{body}/{q}"
    return sign + body


def poly_text(coeffs_high_first: Sequence[Fraction | int], *, lex: bool = False) -> str:
    """The text SymPy prints for ``Poly(coeffs, x).as_expr()``: terms by descending degree.

    SymPy's default order has one exception, kept here: a sum of exactly a
    positive constant and one negative term prints the constant first
    (``1 - x**2``).  ``lex=True`` is the ``order='lex'`` of ``CRootOf``'s
    printer, which has no exception.

    Examples
    --------
    >>> from fractions import Fraction as F
    >>> poly_text([1, F(-63, 25), F(28159, 10000), F(-221831, 125000)])
    'x**3 - 63*x**2/25 + 28159*x/10000 - 221831/125000'
    >>> poly_text([-1, 0, F(1, 7), 1])
    '-x**3 + x/7 + 1'
    >>> poly_text([-1, 0, F(1, 2)]), poly_text([-1, 0, F(1, 2)], lex=True)
    ('1/2 - x**2', '-x**2 + 1/2')
    """
    d = len(coeffs_high_first) - 1
    terms = [(Fraction(c), d - i) for i, c in enumerate(coeffs_high_first) if c != 0]
    if not lex and len(terms) == 2 and terms[1][1] == 0 and terms[1][0] > 0 and terms[0][0] < 0:
        terms.reverse()
    out = ""
    for c, k in terms:
        t = _term(c, k)
        if not out:
            out = t
        elif t.startswith("-"):
            out += " - " + t[1:]
        else:
            out += " + " + t
    return out or "0"


def crootof_text(int_coeffs_low_first: Sequence[int], index: int) -> str | None:
    """``str(CRootOf(f, index))`` for a primitive integer ``f`` with positive leading coefficient, degree >= 2.

    SymPy's ``CRootOf`` clears denominators and takes the primitive part of
    ``f`` (pass :func:`kfio.structure._balls.integer_coeffs`).  It also
    rescales ``x = b y`` when every coefficient ``c_k`` of ``x^k`` below the
    leading one is divisible by ``b^(n - k)`` and the constant term outweighs
    the leading one (``x**2 + 25`` gives ``5*CRootOf(x**2 + 1, 0)``); then
    expressions built on the root change shape too, and this returns ``None``
    for the caller to print with SymPy.  The rescaling needs a common factor
    ``b > 1`` of those coefficients, so when their gcd is 1 the text is the
    plain ``CRootOf``.

    Examples
    --------
    >>> crootof_text((-1, -3, 0, 1), 2)
    'CRootOf(x**3 - 3*x - 1, 2)'
    >>> crootof_text((25, 0, 1), 0) is None
    True
    """
    lead, const = abs(int_coeffs_low_first[-1]), abs(int_coeffs_low_first[0])
    if lead < const and math.gcd(*int_coeffs_low_first[:-1]) > 1:
        return None
    return f"CRootOf({poly_text(list(reversed(int_coeffs_low_first)), lex=True)}, {index})"


__all__ = ["crootof_text", "poly_text"]
