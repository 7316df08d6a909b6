"""Exact values as objects: a :class:`fractions.Fraction` for a rational, :class:`ExactReal` otherwise.

Reports carry every exact value as text (``critical_arrival_probability_exact
= "9/25"``), which is what the JSON holds.  :func:`exact_value` turns such a
text into an object for Python code: a rational text (``"9/25"``, ``"-3"``)
becomes the ``Fraction`` it denotes; any other text (an algebraic number
such as ``"1 - 2**(2/3)/4"`` or a ``CRootOf`` expression, or a closed form
such as the tail exponent ``"log(5/2)/log(25/16)"``) becomes an
:class:`ExactReal` that keeps the exact text and converts with ``float()``.  The text is never evaluated: the float
is the one kfio computed beside it (at 40 digits, rounded once).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from fractions import Fraction
from typing import SupportsFloat

#: The rational texts kfio writes (:func:`kfio.model._exact.fraction_text`): ``"9/25"``, ``"-3"``, ``"0"``.
_RATIONAL = re.compile(r"-?[0-9]+(/[0-9]+)?")


@dataclass(frozen=True)
class ExactReal:
    """An exact real number that is not written as a rational: its exact text and its float.

    An algebraic number (``sqrt(10)/10``, a ``CRootOf``) or a closed form
    (``log(5/2)/log(25/16)``, a tail exponent).

    ``str(x)`` is the exact text (SymPy's printing, as in the JSON), ``float(x)``
    the nearest double kfio computed; :class:`OverflowError` when the value is
    outside float64's range (the JSON's float is then ``null``).

    Examples
    --------
    >>> x = ExactReal("1 - 2**(2/3)/4", 0.6031497370079506)
    >>> str(x), round(float(x), 6)
    ('1 - 2**(2/3)/4', 0.60315)
    """

    text: str
    approx: float | None = None

    def __float__(self) -> float:
        if self.approx is None:
            raise OverflowError(f"{self.text} has no float64 value (outside its range)")
        return self.approx

    def __str__(self) -> str:
        return self.text


def exact_value(text: str, approx: SupportsFloat | None = None) -> Fraction | ExactReal:
    """The exact value that a report's text denotes: a ``Fraction`` if rational, else an :class:`ExactReal`.

    Parameters
    ----------
    text:
        An exact text of a report (a ``*_exact`` field, or such a key of its JSON).
    approx:
        The float beside it in the report (the field without ``_exact``); it is
        what ``float()`` of an :class:`ExactReal` returns.  Unused for a rational.

    Examples
    --------
    >>> exact_value("9/25"), exact_value("-3")
    (Fraction(9, 25), Fraction(-3, 1))
    >>> exact_value("sqrt(2)", 1.4142135623730951)
    ExactReal(text='sqrt(2)', approx=1.4142135623730951)
    """
    if _RATIONAL.fullmatch(text):
        return Fraction(text)
    return ExactReal(text, None if approx is None else float(approx))


__all__ = ["ExactReal", "exact_value"]
