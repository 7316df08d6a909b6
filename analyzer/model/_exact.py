"""Exact numbers from user text.

A JSON number means its *decimal text*: ``1.1`` is ``11/10``, never the
nearest double.  Strings may hold an integer, a decimal with optional
exponent, or a fraction ``"p/q"``.  Nothing the user sends ever reaches
``eval`` or ``sympify``: numbers are recognised by one regular expression and
built with :class:`fractions.Fraction` from integer parts.
"""

from __future__ import annotations

import json
import re
from decimal import Decimal
from fractions import Fraction
from typing import Any

from ..errors import InvalidInput, LimitExceeded

_DECIMAL = r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?"
_NUMBER_RE = re.compile(rf"^\s*({_DECIMAL})\s*(?:/\s*({_DECIMAL})\s*)?$")
_PARTS_RE = re.compile(r"^([+-]?)(\d*)(?:\.(\d*))?(?:[eE]([+-]?\d+))?$")


def _decimal_text_to_fraction(text: str, field: str, max_digits: int) -> Fraction:
    m = _PARTS_RE.match(text)
    if m is None:  # pragma: no cover - guarded by _NUMBER_RE
        raise InvalidInput(field, f"{text!r} is not a number")
    sign, whole, frac, exp = m.groups()
    frac = frac or ""
    digits = (whole + frac).lstrip("0")
    if len(digits) > max_digits:
        raise LimitExceeded(field, f"numbers may have at most {max_digits} digits")
    e = int(exp) if exp else 0
    if abs(e) > 4 * max_digits:
        raise LimitExceeded(field, f"exponent {e} is beyond the limit of {4 * max_digits}")
    mantissa = int(whole + frac) if (whole + frac) else 0
    e -= len(frac)
    value = Fraction(mantissa * 10**e) if e >= 0 else Fraction(mantissa, 10 ** (-e))
    if len(str(value.numerator)) > max_digits or len(str(value.denominator)) > max_digits:
        raise LimitExceeded(field, f"numbers may have at most {max_digits} digits")
    return -value if sign == "-" else value


def parse_number(value: Any, field: str, max_digits: int = 200) -> Fraction:
    """Return the exact rational that ``value`` denotes.

    Parameters
    ----------
    value:
        ``int``, :class:`decimal.Decimal` (how :func:`load_json` keeps JSON
        numbers), or ``str`` such as ``"11/10"``, ``"-3/4"``, ``"1.1e-3"``.
        Python ``float`` is accepted only for programmatic callers and is read
        through its shortest ``repr`` (``0.1`` -> ``1/10``), never through its
        binary value.
    field:
        JSON pointer used in error messages.

    Raises
    ------
    InvalidInput
        Booleans, ``None``, NaN, infinities, text that is not a number, zero
        denominators.
    LimitExceeded
        More than ``max_digits`` digits.

    Examples
    --------
    >>> parse_number(Decimal("1.1"), "/x")
    Fraction(11, 10)
    >>> parse_number("-3/4", "/x")
    Fraction(-3, 4)
    """
    if isinstance(value, bool) or value is None:
        raise InvalidInput(field, f"expected a number, got {json.dumps(value)}")
    if isinstance(value, int):
        if len(str(abs(value))) > max_digits:
            raise LimitExceeded(field, f"numbers may have at most {max_digits} digits")
        return Fraction(value)
    if isinstance(value, float):
        value = repr(float(value))  # numpy.float64 is a float whose repr is "np.float64(0.5)"
    if isinstance(value, Decimal):
        if not value.is_finite():
            raise InvalidInput(field, "NaN and infinities are not numbers")
        value = str(value)
    if not isinstance(value, str):
        raise InvalidInput(field, f"expected a number, got a {_json_type(value)}")
    if len(value) > 4 * max_digits + 16:
        raise LimitExceeded(field, f"numbers may have at most {max_digits} digits")
    m = _NUMBER_RE.match(value)
    if m is None:
        raise InvalidInput(
            field,
            f"{value[:40]!r} is not a number (use an integer, a decimal such as "
            "'1.1e-3', or a fraction such as '11/10')",
        )
    num = _decimal_text_to_fraction(m.group(1), field, max_digits)
    if m.group(2) is None:
        return num
    den = _decimal_text_to_fraction(m.group(2), field, max_digits)
    if den == 0:
        raise InvalidInput(field, "division by zero")
    return num / den


def _json_type(value: Any) -> str:
    if isinstance(value, dict):
        return "object"
    if isinstance(value, (list, tuple)):
        return "array"
    if isinstance(value, str):
        return "string"
    return type(value).__name__


def _reject_constant(name: str) -> Any:
    raise InvalidInput("/", f"{name} is not a number (NaN and infinities are rejected)")


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, val in pairs:
        if key in out:
            raise InvalidInput("/", f"duplicate key {key!r} in a JSON object")
        out[key] = val
    return out


def load_json(text: str | bytes) -> Any:
    """Parse request JSON keeping every number exact.

    Floats become :class:`decimal.Decimal` (their text, exactly), NaN and
    infinities and duplicate keys are rejected.

    Raises
    ------
    InvalidInput
        Text that is not JSON, with the line and column of the problem.
    """
    if isinstance(text, bytes):
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise InvalidInput("/", f"request is not UTF-8 text ({exc.reason})") from None
    try:
        return json.loads(
            text,
            parse_float=Decimal,
            parse_constant=_reject_constant,
            object_pairs_hook=_no_duplicates,
        )
    except json.JSONDecodeError as exc:
        raise InvalidInput("/", f"not valid JSON: {exc.msg} at line {exc.lineno} column {exc.colno}") from None
    except RecursionError:
        raise InvalidInput("/", "JSON nested too deeply") from None
    except ValueError as exc:  # int() digit limit of CPython
        if isinstance(exc, InvalidInput):
            raise
        raise InvalidInput("/", f"not valid JSON: {exc}") from None


def fraction_text(x: Fraction) -> str:
    """Canonical text of a rational: ``"9/25"``, ``"-3"``."""
    return str(x.numerator) if x.denominator == 1 else f"{x.numerator}/{x.denominator}"
