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
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from decimal import Decimal
from fractions import Fraction
from typing import Any

from ..errors import ECHO_LIMIT, InvalidInput, LimitExceeded, clip

# The grammar is ASCII: ``\d`` and ``str.isdigit`` would accept other scripts' digits
# ("\u0661.\u0662\u0665" is 1.25 in Arabic-Indic digits).  A string holds the number and nothing
# else: no whitespace around it or around the slash, so a string the schema's pattern refuses is
# never a number here either, and " 1" is not one.
_DIGITS = "[0-9]"
DECIMAL_PATTERN = rf"[+-]?(?:{_DIGITS}+(?:\.{_DIGITS}*)?|\.{_DIGITS}+)(?:[eE][+-]?{_DIGITS}+)?"
#: A number in a string: a decimal, or a fraction of two decimals.
_NUMBER_RE = re.compile(rf"({DECIMAL_PATTERN})(?:/({DECIMAL_PATTERN}))?", re.ASCII)
_PARTS_RE = re.compile(rf"([+-]?)({_DIGITS}*)(?:\.({_DIGITS}*))?(?:[eE]([+-]?{_DIGITS}+))?", re.ASCII)
#: Exponent digits kept by :func:`load_json`; a longer exponent is clamped (the value is far
#: beyond every limit either way, and :mod:`decimal` refuses exponents above 10^18).
_MAX_EXPONENT_DIGITS = 15


def _decimal_text_to_fraction(text: str, field: str, max_digits: int) -> Fraction:
    m = _PARTS_RE.fullmatch(text)
    if m is None:  # pragma: no cover - guarded by _NUMBER_RE
        raise InvalidInput(field, f"{value_text(text)} is not a number")
    sign, whole, frac, exp = m.groups()
    frac = frac or ""
    digits = (whole + frac).lstrip("0")
    if len(digits) > max_digits:
        raise LimitExceeded(field, f"numbers may have at most {max_digits} digits")
    exp = (exp or "0").lstrip("+")
    if len(exp.lstrip("-").lstrip("0")) > len(str(4 * max_digits)) or abs(int(exp)) > 4 * max_digits:
        raise LimitExceeded(field, f"the exponent of a number must lie in [-{4 * max_digits}, {4 * max_digits}]")
    e = int(exp)
    mantissa = int(whole + frac) if (whole + frac) else 0
    e -= len(frac)
    value = Fraction(mantissa * 10**e) if e >= 0 else Fraction(mantissa, 10 ** (-e))
    for part, n in (("numerator", value.numerator), ("denominator", value.denominator)):
        if len(str(n)) > max_digits:  # few digits, a far exponent: 1e-300 is 1/10^300
            raise LimitExceeded(
                field,
                f"the exact value of this number has {len(str(n))} digits in its {part}; numerator and "
                f"denominator may have at most {max_digits} digits each (an exponent adds digits: 1e-300 is 1/10^300)",
            )
    return -value if sign == "-" else value


def number_text_limit(max_digits: int) -> int:
    """Most characters of a number written as text: ``4 * max_digits + 16``.

    Two parts of at most ``max_digits`` digits, their exponents (at most
    ``4 * max_digits`` in magnitude), signs and marks.
    """
    return 4 * max_digits + 16


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
    if len(value) > number_text_limit(max_digits):
        raise LimitExceeded(field, f"the text of a number may have at most {number_text_limit(max_digits)} characters")
    m = _NUMBER_RE.fullmatch(value)
    if m is None:
        raise InvalidInput(
            field,
            f"{value_text(value)} is not a number (use an integer, a decimal such as "
            "'1.1e-3', or a fraction such as '11/10', with no spaces)",
        )
    num = _decimal_text_to_fraction(m.group(1), field, max_digits)
    if m.group(2) is None:
        return num
    den = _decimal_text_to_fraction(m.group(2), field, max_digits)
    if den == 0:
        raise InvalidInput(field, "division by zero")
    return num / den


def parse_integer(value: Any, field: str, lo: int, hi: int | None = None, name: str = "the value") -> int:
    """An integer option, range-checked from its decimal text before any conversion.

    A JSON number such as ``1e999999999`` is kept by :func:`load_json` as a
    :class:`decimal.Decimal`; converting it to ``int`` would build a
    billion-digit integer.  Comparisons of a ``Decimal`` with the bounds look
    at its exponent first, so the range is checked at no cost, and only a
    value inside ``[lo, hi]`` is converted.  Integral decimals (``1e3``,
    ``200.0``) are integers.

    Raises
    ------
    InvalidInput
        Not a number, not integral, or below ``lo``.
    LimitExceeded
        Above ``hi``.

    Examples
    --------
    >>> parse_integer(Decimal("1e3"), "/x", 1, 10**6)
    1000
    >>> parse_integer(Decimal("1e999999999"), "/x", 1, 41, "grid")
    Traceback (most recent call last):
    ...
    kfio.errors.LimitExceeded: /x: grid must be at most 41; got 1e999999999
    """
    if isinstance(value, bool) or not isinstance(value, (int, Decimal)):
        raise InvalidInput(field, f"{name} must be an integer; got {value_text(value)}")
    if isinstance(value, Decimal) and not value.is_finite():
        raise InvalidInput(field, f"{name} must be an integer; got {value_text(value)}")
    if value < lo:
        raise InvalidInput(field, f"{name} must be at least {lo}; got {value_text(value)}")
    if hi is not None and value > hi:
        raise LimitExceeded(field, f"{name} must be at most {hi}; got {value_text(value)}")
    if isinstance(value, Decimal):
        if hi is None and value.adjusted() >= _MAX_UNBOUNDED_DIGITS:
            raise LimitExceeded(field, f"{name} must have at most {_MAX_UNBOUNDED_DIGITS} digits")
        if value != value.to_integral_value():
            raise InvalidInput(field, f"{name} must be an integer; got {value_text(value)}")
        return int(value)
    return value


#: Digits allowed in an integer option without an upper bound of its own.
_MAX_UNBOUNDED_DIGITS = 30


#: Set while validating what a check file's plant, channel or loop file holds (:func:`values_withheld`).
_WITHHELD: ContextVar[bool] = ContextVar("kfio_values_withheld", default=False)
#: What :func:`value_text` shows for a withheld value.
WITHHELD_TEXT = "<value not shown>"


@contextmanager
def values_withheld() -> Iterator[None]:
    """Within it, :func:`value_text` shows no client value, only :data:`WITHHELD_TEXT`.

    ``kfio check`` validates plant, channel and loop files inside it: those files
    are named by a check file that may come from anyone (a pull request), and an
    error about them goes to CI logs and JUnit.  The field and the rule still
    say what is wrong; the value, which might be a credential the path led to,
    is not repeated.

    Examples
    --------
    >>> with values_withheld():
    ...     value_text("hunter2")
    '<value not shown>'
    """
    token = _WITHHELD.set(True)
    try:
        yield
    finally:
        _WITHHELD.reset(token)


def value_text(value: Any, limit: int = 40) -> str:
    """A user value as it would appear in JSON, for messages: never a Python repr, never huge.

    Strings are JSON-quoted with non-ASCII escaped (so a lone surrogate prints
    as ``\\ud800``), numbers are their decimal text, containers are named.
    Every message that quotes a client's value (a key, a name, a number's
    text, an option's value) quotes it through here: at most ``limit``
    characters (at most :data:`kfio.errors.ECHO_LIMIT`), and nothing at all
    inside :func:`values_withheld`.

    Examples
    --------
    >>> value_text(Decimal("1E+999999")), value_text("x"), value_text(True), value_text([1])
    ('1e999999', '"x"', 'true', 'a JSON array')
    >>> value_text("k" * 1000, 10)
    '"kkkkkk...'
    """
    limit = min(limit, ECHO_LIMIT)
    if _WITHHELD.get():
        return WITHHELD_TEXT
    if isinstance(value, Decimal):
        text = str(value).lower().replace("e+", "e")
    elif isinstance(value, int) and not isinstance(value, bool):
        text = str(value) if abs(value) < 10**limit else f"an integer of more than {limit} digits"
    elif isinstance(value, (str, bool, float)) or value is None:
        text = json.dumps(value, ensure_ascii=True)
    else:
        return f"a JSON {_json_type(value)}"
    return text if len(text) <= limit else clip(text, limit - 3)


def _json_type(value: Any) -> str:
    if isinstance(value, dict):
        return "object"
    if isinstance(value, (list, tuple)):
        return "array"
    if isinstance(value, str):
        return "string"
    return type(value).__name__


def _json_decimal(text: str) -> Decimal:
    """A JSON number with a fraction or exponent, exactly (its exponent clamped, see ``_MAX_EXPONENT_DIGITS``)."""
    mantissa, sep, exp = text.replace("E", "e").partition("e")
    if sep and len(exp.lstrip("+-")) > _MAX_EXPONENT_DIGITS:
        sign = "-" if exp.startswith("-") else ""
        text = f"{mantissa}e{sign}1{'0' * _MAX_EXPONENT_DIGITS}"
    return Decimal(text)


def _reject_constant(name: str) -> Any:
    raise InvalidInput("/", f"{name} is not a number (NaN and infinities are rejected)")


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, val in pairs:
        if key in out:
            raise InvalidInput("/", f"duplicate key {value_text(key)} in a JSON object")
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

    Examples
    --------
    >>> load_json('{"A": [[1.1]]}')
    {'A': [[Decimal('1.1')]]}
    """
    if isinstance(text, bytes):
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise InvalidInput("/", f"request is not UTF-8 text ({exc.reason})") from None
    try:
        tree = json.loads(
            text,
            parse_float=_json_decimal,
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
        if "digits" in str(exc):  # CPython's text names its own setting, which a client cannot change
            raise LimitExceeded(
                "/",
                f"a JSON integer has more than {sys.get_int_max_str_digits()} digits; numbers are limited to far fewer",
            ) from None
        raise InvalidInput("/", f"not valid JSON: {exc}") from None
    if _may_hold_surrogates(text):
        _reject_lone_surrogates(tree)
    return tree


def escaped(text: str) -> str:
    """``text`` with lone surrogates written as backslash escapes (safe to encode, print and send).

    Examples
    --------
    >>> print(escaped("s" + chr(0xD800)))
    s\\ud800
    """
    if text.isascii():
        return text
    return text.encode("utf-8", "backslashreplace").decode("utf-8")


#: A JSON escape of a surrogate code point (U+D800 to U+DFFF), in either case.
_SURROGATE_ESCAPE = re.compile(r"\\u[dD][89abcdefABCDEF]")


def _may_hold_surrogates(text: str) -> bool:
    """Whether the parsed tree can hold a surrogate: the text has one, raw or as an escape.

    A scan of the text at C speed; the tree walk runs only when this is true
    (a 1 MiB request of plain numbers costs no walk).
    """
    return _has_lone_surrogate(text) or _SURROGATE_ESCAPE.search(text) is not None


def _has_lone_surrogate(text: str) -> bool:
    if text.isascii():
        return False
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return True
    return False


def _reject_lone_surrogates(tree: Any) -> None:
    """Refuse strings (keys or values) that are not Unicode text.

    JSON's ``\\ud800`` escape can denote a lone surrogate, which is no
    character at all (RFC 8259, section 8.2); I-JSON (RFC 7493, section 2.1)
    forbids it.  Such a string cannot be encoded as UTF-8, so it could not be
    echoed in a report or an error message; it is refused here, once, for
    every field name, sensor name, channel key, history key and option key.
    """
    stack: list[tuple[Any, tuple[str, ...]]] = [(tree, ())]  # depth first, in document order
    while stack:
        node, path = stack.pop()
        if isinstance(node, str):
            if _has_lone_surrogate(node):
                raise InvalidInput(_path_pointer(path), _SURROGATE_RULE)
        elif isinstance(node, dict):
            children = []
            for key, val in node.items():
                if _has_lone_surrogate(key):
                    raise InvalidInput(_path_pointer((*path, key)), _SURROGATE_RULE)
                children.append((val, (*path, key)))
            stack.extend(reversed(children))
        elif isinstance(node, list):
            stack.extend((node[i], (*path, str(i))) for i in reversed(range(len(node))))


_SURROGATE_RULE = (
    "strings must be Unicode text: a lone surrogate escape such as \\ud800 is not a character "
    "(RFC 8259 section 8.2, RFC 7493 section 2.1)"
)


def _path_pointer(path: tuple[str, ...]) -> str:
    from ._pointer import json_pointer

    return json_pointer(escaped(p) for p in path)


def fraction_text(x: Fraction) -> str:
    """Canonical text of a rational: ``"9/25"``, ``"-3"``."""
    return str(x.numerator) if x.denominator == 1 else f"{x.numerator}/{x.denominator}"


#: Exact texts of computed values with more digits than this are reported as null with a
#: digit count and a decimal enclosure (the same cap as the digits of an input number).
MAX_EXACT_DIGITS = 200


def _digits(k: int) -> int:
    """Decimal digits of ``|k|`` without converting it to text (Python refuses texts over 4300 digits)."""
    k = abs(k)
    if k < 10:
        return 1
    guess = int(k.bit_length() * 0.30102999566398120)  # log10(2): the true count is guess or guess + 1
    return guess + 1 if k >= 10**guess else guess


def fraction_digits(x: Fraction) -> int:
    """Digits of :func:`fraction_text` of ``x`` (numerator, and denominator when not 1)."""
    return _digits(x.numerator) + (0 if x.denominator == 1 else _digits(x.denominator))


def decimal_enclosure(lo: Fraction, hi: Fraction, digits: int = 17) -> tuple[str, str]:
    """Decimal texts ``(a, b)`` with ``a <= lo`` and ``hi <= b``, ``digits`` significant digits, rounded outward."""

    def text(x: Fraction, up: bool) -> str:
        if x == 0:
            return "0"
        e = _digits(x.numerator) - _digits(x.denominator) - digits  # 10^e: a step of about `digits` digits
        step = Fraction(10) ** e
        q, r = divmod(x.numerator * step.denominator, x.denominator * step.numerator)
        k = q + (1 if up and r else 0)
        mant = str(abs(k))
        sign = "-" if k < 0 else ""
        power = len(mant) - 1 + e  # x is about mant[0].mant[1:] * 10^power
        if abs(power) > 20:
            tail = mant[1:].rstrip("0")
            return f"{sign}{mant[0]}{'.' + tail if tail else ''}e{power}"
        if e >= 0:
            return sign + mant + "0" * e
        point = len(mant) + e
        body = mant[:point] + "." + mant[point:] if point > 0 else "0." + "0" * (-point) + mant
        return sign + body.rstrip("0").rstrip(".")

    return text(lo, False), text(hi, True)


def capped_fraction_text(
    x: Fraction | None, cap: int = MAX_EXACT_DIGITS
) -> tuple[str | None, int | None, tuple[str, str] | None]:
    """``(text, digits, enclosure)`` of an exact value: the text when it has at most ``cap`` digits, else
    ``None`` with its digit count and a 17-digit decimal enclosure (:func:`decimal_enclosure`).

    >>> capped_fraction_text(Fraction(9, 25))
    ('9/25', 3, None)
    >>> capped_fraction_text(Fraction(1, 3**500))
    (None, 240, ('2.750252956203138e-239', '2.7502529562031381e-239'))
    """
    if x is None:
        return None, None, None
    n = fraction_digits(x)
    if n <= cap:
        return fraction_text(x), n, None
    return None, n, decimal_enclosure(x, x)
