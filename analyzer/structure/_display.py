"""Short human-readable forms of long exact algebraic numbers.

The JSON reports keep every exact number whole (``CRootOf(...)`` with
60-digit coefficients, nested radicals); a terminal summary shows
``root of a degree-3 polynomial, 0.126077`` instead.  Only the display
changes: nothing here feeds back into a decision.
"""

from __future__ import annotations

import re
from typing import Any

import sympy

from .._numbers import decimal_text
from ._eigen import X

#: Exact texts longer than this many characters are shortened in summaries.
SHORT_TEXT_CHARS = 40

_ROOT_OF = re.compile(r"^root of (?P<poly>.+) near ")
_POWER = re.compile(r"\*\*(\d+)")


def algebraic_degree(expr: Any) -> int | None:
    """Degree over ``Q`` of the algebraic number ``expr``, or ``None`` if SymPy cannot tell.

    The degree of the minimal polynomial: 1 for a rational, 2 for
    ``a + b sqrt(c)`` with ``c`` not a square, ``deg f`` for a root of an
    irreducible ``f``.

    Examples
    --------
    >>> from sympy import CRootOf, Rational, sqrt
    >>> algebraic_degree(Rational(9, 25)), algebraic_degree(1 - 1 / sqrt(2))
    (1, 2)
    >>> algebraic_degree(1 - 1 / CRootOf(X**3 - 3 * X - 1, 2) ** 2)
    3
    """
    try:
        return int(sympy.minimal_polynomial(expr, X, polys=True).degree())
    except (NotImplementedError, ValueError, TypeError, sympy.polys.polyerrors.PolynomialError):
        return None


def _degree_from_text(text: str) -> int | None:
    """The degree, read from the two text forms kfio itself writes for eigenvalues."""
    m = _ROOT_OF.match(text)
    if m:
        powers = [int(p) for p in _POWER.findall(m.group("poly"))]
        return max(powers, default=1)
    if "sqrt(" in text and "CRootOf" not in text and "**" not in text:
        return 2  # a quadratic radical a + b*sqrt(c) (times I): the roots of a quadratic factor
    return None


def short_text(
    text: str,
    value: complex | float,
    degree: int | None = None,
    *,
    max_chars: int = SHORT_TEXT_CHARS,
    digits: int = 6,
) -> str:
    """``text`` itself when short, else ``"root of a degree-d polynomial, <value>"``.

    Parameters
    ----------
    text:
        The exact text of a number as the JSON report carries it.
    value:
        Its numerical value (real or complex).
    degree:
        Its degree over ``Q`` when the caller knows it (:func:`algebraic_degree`);
        otherwise it is read from the text forms kfio writes for eigenvalues
        (``"root of <f> near ..."``, quadratic radicals), and when that fails
        too the text says only ``"algebraic number"``.
    max_chars:
        Texts up to this length are returned unchanged.
    digits:
        Significant digits of the value shown.

    Examples
    --------
    >>> short_text("9/25", 0.36)
    '9/25'
    >>> short_text("1 - 1/CRootOf(15625000000000000*x**3 - 31311332551810115*x + 1, 1)", 0.126077, 3)
    'root of a degree-3 polynomial, 0.126077'
    >>> short_text("root of x**4 + 123456789/1000000000 near 0.4191+0.4191i", 0.4191 + 0.4191j)
    'root of a degree-4 polynomial, 0.4191+0.4191i'
    """
    if len(text) <= max_chars:
        return text
    if degree is None:
        degree = _degree_from_text(text)
    shown = decimal_text(value, digits)
    if degree is None:
        return f"algebraic number, {shown}"
    return f"root of a degree-{degree} polynomial, {shown}"


#: Fractions whose text is longer than this are shown as ``~`` and a decimal in summaries and reprs.
SHORT_FRACTION_CHARS = 12
_RATIONAL = re.compile(r"-?\d+(/\d+)?")


def readable(text: str, value: complex | float | None = None, degree: int | None = None) -> str:
    """What a person reads for an exact number: short texts as they are, long ones as a decimal.

    A rational with a long text (a ``control.c2d`` entry,
    ``2501225941561293/2500000000000000``) becomes ``~`` and 6 significant
    digits; a long algebraic text becomes :func:`short_text`'s
    ``root of a degree-d polynomial, <value>``.  The exact text stays in the
    JSON; nothing here feeds back into a decision.

    Examples
    --------
    >>> readable("11/10"), readable("2501225941561293/2500000000000000")
    ('11/10', '~1.00049')
    >>> readable("7/8 - sqrt(7009)/200", 0.456401)
    '7/8 - sqrt(7009)/200'
    """
    if _RATIONAL.fullmatch(text):
        if len(text) <= SHORT_FRACTION_CHARS:
            return text
        from fractions import Fraction

        return f"~{float(Fraction(text)):.6g}"
    if value is None:
        return text
    return short_text(text, value, degree)


__all__ = ["SHORT_FRACTION_CHARS", "SHORT_TEXT_CHARS", "algebraic_degree", "readable", "short_text"]
