"""One number format for every surface a person or a pipeline reads: a decimal first, the exact form beside it when short.

The JSON reports keep every exact number whole (``1 - 1/CRootOf(15625000...*x**3 - ..., 1)``, a
60-digit fraction); a terminal line, a table cell, a plot label or the page shows

* ``0.5625 = 9/16``: a decimal, and the exact form when it is a fraction or radical of at most
  :data:`EXACT_CAP` characters (nothing when the decimal is the number itself, ``0.5``);
* ``0.237112 (algebraic, degree 3)``: a longer algebraic number, its degree over ``Q`` read from
  the text (the minimal polynomial is in ``--json``);
* ``0.305562 (from float data)``: a long exact value whose integers carry the long runs of zeros
  of decimals with many digits (a ``control.c2d`` plant, float gains): its digits are the float's,
  and printing them as a fraction would claim a precision the data never had.

Only the display changes: nothing here feeds back into a decision.  Exact texts are read by
:func:`exact_value`, a small parser of the forms kfio writes (integers, decimals, ``+ - * / **``,
``sqrt``, ``CRootOf``, ``log``, ``exp``, ``I``, ``pi``): no ``eval``, no ``sympify``.
"""

from __future__ import annotations

import functools
import math
import re
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

#: Exact forms up to this many characters are shown beside the decimal.
EXACT_CAP = 24
#: Significant digits of the decimal.
DIGITS = 6
#: An integer with at least this many trailing zeros in an exact text is the mark of decimal data
#: with many digits (``2500000000000000``): such a value is labelled "from float data".
FLOAT_DATA_ZEROS = 10
#: Texts longer than this are not parsed (a summary does not need their decimal that badly).
MAX_PARSE_CHARS = 20000

_TOKEN = re.compile(r"\s*(?:(\d+\.\d*(?:[eE][-+]?\d+)?|\d+(?:[eE][-+]?\d+)?)|(\*\*|[-+*/(),])|([A-Za-z_]\w*))")
_INTEGER = re.compile(r"\d+")
_RATIONAL = re.compile(r"-?\d+(?:/\d+)?")


@dataclass(frozen=True)
class Shown:
    """A number as shown: ``decimal`` (always), ``exact`` (the short exact form or ``""``) and ``note``.

    ``note`` is ``""``, ``"algebraic, degree d"``, ``"from float data"``, ``"N-digit fraction"`` or
    ``"closed form"``: what is in the JSON when ``exact`` is not shown.
    """

    decimal: str
    exact: str
    note: str

    @property
    def text(self) -> str:
        """One cell: ``decimal``, ``decimal = exact`` or ``decimal (note)``."""
        if self.exact:
            return f"{self.decimal} = {self.exact}"
        if self.note:
            return f"{self.decimal} ({self.note})"
        return self.decimal

    @property
    def exact_column(self) -> str:
        """What an ``_exact`` table column holds: the short exact form, else the note."""
        return self.exact or self.note


def decimal_text(value: complex | float | Fraction | int, digits: int = DIGITS) -> str:
    """``value`` to ``digits`` significant digits (``0.237112``, ``1.5e-07``, ``0.5+0.2i``).

    Examples
    --------
    >>> decimal_text(Fraction(9, 16)), decimal_text(0.2371124), decimal_text(complex(0.5, -0.25))
    ('0.5625', '0.237112', '0.5-0.25i')
    """
    if isinstance(value, (Fraction, int)):
        return f"{float(value):.{digits}g}"
    z = complex(value)
    scale = max(abs(z.real), abs(z.imag), 1e-300)
    if abs(z.imag) <= 1e-14 * scale:
        return f"{z.real:.{digits}g}"
    if abs(z.real) <= 1e-14 * scale:
        return f"{z.imag:.{digits}g}i"
    return f"{z.real:.{digits}g}{z.imag:+.{digits}g}i"


def looks_like_float_data(text: str) -> bool:
    """Whether an exact text holds an integer with :data:`FLOAT_DATA_ZEROS` trailing zeros or more.

    Decimals with many digits (``0.9987502603949663``) become fractions over ``10^16``; every
    exact value computed from them keeps such powers of ten in its integers.

    Examples
    --------
    >>> looks_like_float_data("2501225941561293/2500000000000000"), looks_like_float_data("75/152")
    (True, False)
    """
    return any(len(m) - len(m.rstrip("0")) >= FLOAT_DATA_ZEROS for m in _INTEGER.findall(text))


def show(
    exact: str | None,
    value: complex | float | None = None,
    *,
    from_float: bool | None = None,
    cap: int = EXACT_CAP,
    digits: int = DIGITS,
) -> Shown:
    """The parts of a number as people read it: decimal, short exact form, or a note on the long one.

    Parameters
    ----------
    exact:
        The exact text as the JSON report carries it (``"9/16"``, ``"1 - 1/CRootOf(...)"``), or
        ``None`` when there is none (the decimal alone is shown).
    value:
        The numerical value; read from ``exact`` (:func:`exact_value`) when not given.
    from_float:
        Whether the value came from float data; ``None`` reads the text
        (:func:`looks_like_float_data`).
    cap:
        Exact texts up to this length are shown beside the decimal.
    digits:
        Significant digits of the decimal.

    Examples
    --------
    >>> show("9/16").text, show("12").text, show("7/8 - sqrt(7009)/200").text
    ('0.5625 = 9/16', '12', '0.456401 = 7/8 - sqrt(7009)/200')
    >>> show("1 - 1/CRootOf(x**3 - 3*x - 1, 2)**2 + 1/CRootOf(x**3 - 3*x - 1, 2)").text
    '1.24897 (algebraic, degree 3)'
    >>> show("70400000000000000000000000000/230395516585597167079575641111").text
    '0.305562 (from float data)'
    """
    parsed = None
    if exact is not None and (value is None or len(exact) > cap):
        parsed = _parse_or_none(exact)
    if value is None:
        if parsed is None:
            return Shown(exact or "none", "", "")
        value = parsed.value
    decimal = decimal_text(value, digits)
    if exact is None or exact == decimal:
        return Shown(decimal, "", "")
    rational = _RATIONAL.fullmatch(exact)
    if rational and "/" not in exact and Fraction(exact) == _decimal_fraction(decimal):
        return Shown(decimal, "", "")  # an integer the decimal shows whole
    if len(exact) <= cap:
        return Shown(decimal, exact, "")
    if from_float is None:
        from_float = looks_like_float_data(exact)
    if from_float:
        return Shown(decimal, "", "from float data")
    if rational:
        digits_long = max(len(part.lstrip("-")) for part in exact.split("/"))
        return Shown(decimal, "", f"{digits_long}-digit fraction")
    if parsed is not None and parsed.degree is not None:
        return Shown(decimal, "", f"algebraic, degree {parsed.degree}")
    return Shown(decimal, "", "closed form")


def number_text(
    exact: str | None, value: complex | float | None = None, *, from_float: bool | None = None, cap: int = EXACT_CAP
) -> str:
    """:func:`show` as one cell: ``0.5625 = 9/16``, ``0.237112 (algebraic, degree 3)``, ``0.305562 (from float data)``.

    The one format of kfio's summaries, tables, plot labels and reprs: a decimal first (6
    significant digits), the exact form beside it only when it is at most ``cap`` characters.

    Examples
    --------
    >>> number_text("3/10"), number_text("75/152", 0.493421), number_text(None, 0.1234567)
    ('0.3 = 3/10', '0.493421 = 75/152', '0.123457')
    """
    return show(exact, value, from_float=from_float, cap=cap).text


_DEGREE_IN_TEXT = re.compile(r"\bdegree-(\d+) polynomial\b")
_NOT_EXACT_PREFIXES = ("~", "root of ", "algebraic number")


def summary_number(
    exact: str | None,
    value: complex | float | None = None,
    *,
    degree: int | None = None,
    readable: str | None = None,
    cap: int = EXACT_CAP,
) -> str:
    """:func:`number_text` for a report's summary line, using what the report knows besides the text.

    ``readable`` is the report's own short form of ``exact`` (a radical kept whole, or
    ``root of a degree-d polynomial, <value>``): when it is an exact form of at most ``cap``
    characters it stands beside the decimal even where :func:`show` would not parse ``exact``;
    its degree, or ``degree``, names a long algebraic number (``algebraic, degree 3``, and
    ``from float data`` beside it when the text carries float data's digits).

    Examples
    --------
    >>> summary_number("9/25", 0.36), summary_number("1", 1.0)
    ('0.36 = 9/25', '1')
    >>> long = "1 - 1/CRootOf(15625000000000000*x**3 - 31311332551810115*x + 1, 1)"
    >>> summary_number(long, 0.126077, readable="root of a degree-3 polynomial, 0.126077")
    '0.126077 (algebraic, degree 3, from float data)'
    """
    shown = show(exact, value, cap=cap)
    if shown.exact or exact is None:
        return shown.text
    if readable is not None and len(readable) <= cap and readable != exact:
        if not readable.startswith(_NOT_EXACT_PREFIXES) and _EXACT_CHARS.match(readable):
            return f"{shown.decimal} = {readable}"
    if degree is None and readable is not None and (m := _DEGREE_IN_TEXT.search(readable)):
        degree = int(m.group(1))
    if degree is not None and degree > 1 and shown.note in ("from float data", "closed form"):
        note = f"algebraic, degree {degree}" + (", from float data" if shown.note == "from float data" else "")
        return f"{shown.decimal} ({note})"
    return shown.text


_LEADING_WORDS = re.compile(r"^((?:[A-Za-z_][A-Za-z_0-9]* )+)(?=[-+(\d])")
_DECIMAL_EQUALS = re.compile(r"^(-?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?) = (.+)$")
_EXACT_CHARS = re.compile(r"^[-+*/()., \w]+$")


def readable_measure(text: str, *, cap: int = EXACT_CAP) -> str:
    """A measured value's text (``"1 - 1/CRootOf(...)"``, ``"12.39 = log(2)/..."``, ``"worst rate 5/9"``) in :func:`number_text`'s form.

    Three shapes are read: an exact text alone; ``<decimal> = <exact>``; leading words, then one
    of those (``worst rate 9/16``, ``<= 2/5``).  Any other text comes back unchanged.

    Examples
    --------
    >>> readable_measure("worst rate 9/16"), readable_measure("<= 2/5"), readable_measure("stable")
    ('worst rate 0.5625 = 9/16', '<= 0.4 = 2/5', 'stable')
    >>> readable_measure("0.693147 = log(2)")
    '0.693147 = log(2)'
    """
    for prefix in ("<= ", ">= ", "< ", "> ", "= "):
        if text.startswith(prefix):
            return prefix + readable_measure(text[len(prefix) :], cap=cap)
    m = _DECIMAL_EQUALS.match(text)
    if m:
        return number_text(m.group(2), float(m.group(1)), cap=cap)
    m = _LEADING_WORDS.match(text)
    if m:
        return m.group(1) + readable_measure(text[m.end(1) :], cap=cap)
    if _EXACT_CHARS.match(text) and any(c.isdigit() for c in text):
        shown = show(text, cap=cap)
        if shown.decimal != text or shown.exact or shown.note:
            return shown.text
    return text


@functools.lru_cache(maxsize=256)
def kind_of(exact: str) -> str:
    """What a long exact text is, for a table cell in its place: ``from float data``, ``algebraic, degree 3``, ...

    Cached: a sweep's rows repeat the same exact texts (a critical probability of one plant).

    Examples
    --------
    >>> kind_of("2501225941561293/2500000000000000"), kind_of("1 - 1/sqrt(2)")
    ('from float data', 'algebraic, degree 2')
    """
    shown = show(exact, cap=0)
    return shown.note or shown.exact


def clip(text: str, width: int) -> str:
    """``text`` cut to ``width`` characters, ending in ``...`` when cut (a table cell's cap).

    Examples
    --------
    >>> clip("short", 10), clip("a long entry name", 10)
    ('short', 'a long ...')
    """
    return text if len(text) <= width else text[: max(0, width - 3)] + "..."


def _decimal_fraction(decimal: str) -> Fraction | None:
    try:
        return Fraction(decimal)
    except (ValueError, ZeroDivisionError):
        return None


# ---------------------------------------------------------------- reading kfio's exact texts


@dataclass(frozen=True)
class Parsed:
    """An exact text read: its ``value`` and its ``degree`` over ``Q`` when it is algebraic and known."""

    value: complex | float
    degree: int | None


def exact_value(text: str) -> Parsed:
    """Read one of kfio's exact texts: its numerical value and, when it is algebraic, its degree over ``Q``.

    The grammar is what kfio writes (SymPy's printing of exact numbers): integers and decimals,
    ``+ - * / **`` and parentheses, ``I``, ``pi``, ``E``, ``sqrt(e)``, ``log(e)``, ``exp(e)`` and
    ``CRootOf(f, k)`` with ``f`` an integer polynomial in ``x``.  The expression is built from
    SymPy objects (no ``eval``, no ``sympify``) and evaluated to 15 digits; its degree is that of
    its minimal polynomial (SymPy's ``minimal_polynomial``) when SymPy finds it.

    Raises
    ------
    ValueError
        A text outside that grammar, or longer than :data:`MAX_PARSE_CHARS`.

    Examples
    --------
    >>> p = exact_value("1 - 1/sqrt(2)")
    >>> round(p.value, 6), p.degree
    (0.292893, 2)
    """
    if len(text) > MAX_PARSE_CHARS:
        raise ValueError("text too long to read")
    import sympy

    expr = _Reader(text).read()
    value = complex(sympy.N(expr, 15))
    degree = None
    if not expr.has(sympy.log, sympy.exp, sympy.pi, sympy.E):
        degree = _degree(expr)
    return Parsed(value.real if value.imag == 0 else value, degree)


def _parse_or_none(text: str) -> Parsed | None:
    try:
        return exact_value(text)
    except (ValueError, ZeroDivisionError, ArithmeticError, TypeError):
        return None


def _degree(expr: Any) -> int | None:
    import sympy

    if expr.is_Rational:
        return 1
    roots = list(expr.atoms(sympy.CRootOf))
    x = sympy.Symbol("x")
    try:
        return int(sympy.minimal_polynomial(expr, x, polys=True).degree())
    except (NotImplementedError, ValueError, TypeError, sympy.polys.polyerrors.PolynomialError):
        pass
    if len(roots) == 1 and not expr.atoms(sympy.Pow) - {p for p in expr.atoms(sympy.Pow) if p.exp.is_Integer}:
        return int(roots[0].poly.degree())  # a rational function of one root: at most its degree
    return None


class _Reader:
    """Recursive descent over the tokens of an exact text; builds SymPy objects directly."""

    FUNCTIONS = ("sqrt", "log", "exp", "CRootOf")

    def __init__(self, text: str) -> None:
        self.tokens: list[tuple[str, str]] = []
        pos = 0
        text = text.strip()
        while pos < len(text):
            m = _TOKEN.match(text, pos)
            if m is None or m.end() == pos:
                raise ValueError(f"unexpected character at {pos}")
            number, op, name = m.groups()
            self.tokens.append(("num", number) if number else ("op", op) if op else ("name", name))
            pos = m.end()
        self.i = 0
        self.polynomial = False  # ``x`` is admitted only inside CRootOf's polynomial

    def read(self) -> Any:
        expr = self._sum()
        if self.i != len(self.tokens):
            raise ValueError("trailing text")
        return expr

    def _peek(self) -> tuple[str, str] | None:
        return self.tokens[self.i] if self.i < len(self.tokens) else None

    def _take(self, kind: str, text: str | None = None) -> str:
        tok = self._peek()
        if tok is None or tok[0] != kind or (text is not None and tok[1] != text):
            raise ValueError(f"expected {text or kind}")
        self.i += 1
        return tok[1]

    def _sum(self) -> Any:
        expr = self._product()
        while (tok := self._peek()) is not None and tok in (("op", "+"), ("op", "-")):
            self.i += 1
            rhs = self._product()
            expr = expr + rhs if tok[1] == "+" else expr - rhs
        return expr

    def _product(self) -> Any:
        expr = self._unary()
        while (tok := self._peek()) is not None and tok in (("op", "*"), ("op", "/")):
            self.i += 1
            rhs = self._unary()
            expr = expr * rhs if tok[1] == "*" else expr / rhs
        return expr

    def _unary(self) -> Any:
        tok = self._peek()
        if tok in (("op", "-"), ("op", "+")):
            self.i += 1
            inner = self._unary()
            return -inner if tok == ("op", "-") else inner
        return self._power()

    def _power(self) -> Any:
        base = self._atom()
        if self._peek() == ("op", "**"):
            self.i += 1
            exponent = self._unary()
            import sympy

            if exponent.is_Integer and abs(int(exponent)) > 4096:
                raise ValueError("exponent too large to display")
            return sympy.Pow(base, exponent)
        return base

    def _atom(self) -> Any:
        import sympy

        tok = self._peek()
        if tok is None:
            raise ValueError("unexpected end")
        kind, text = tok
        self.i += 1
        if kind == "num":
            if len(text) > 2000:
                raise ValueError("number too long")
            if "." in text or "e" in text.lower():
                return sympy.Rational(Fraction(text).numerator, Fraction(text).denominator)
            return sympy.Integer(int(text))
        if kind == "op":
            if text != "(":
                raise ValueError(f"unexpected {text}")
            expr = self._sum()
            self._take("op", ")")
            return expr
        constants = {"I": sympy.I, "pi": sympy.pi, "E": sympy.E}
        if text in constants:
            return constants[text]
        if text == "x" and self.polynomial:
            return sympy.Symbol("x")
        if text not in self.FUNCTIONS:
            raise ValueError(f"unknown name {text}")
        self._take("op", "(")
        if text == "CRootOf":
            self.polynomial = True
            poly_expr = self._sum()
            self.polynomial = False
            self._take("op", ",")
            sign = -1 if self._peek() == ("op", "-") else 1
            if sign < 0:
                self.i += 1
            index = sign * int(self._take("num"))
            self._take("op", ")")
            x = sympy.Symbol("x")
            poly = sympy.Poly(poly_expr, x)
            if poly.degree() < 1 or not all(c.is_Rational for c in poly.all_coeffs()):
                raise ValueError("CRootOf needs a rational polynomial in x")
            return sympy.CRootOf(poly, index)
        arg = self._sum()
        self._take("op", ")")
        if self.polynomial:
            raise ValueError(f"{text} inside a polynomial")
        return {"sqrt": sympy.sqrt, "log": sympy.log, "exp": sympy.exp}[text](arg)


def finite(value: Any) -> bool:
    """Whether ``value`` is a finite real number (a float that a table can show).

    Examples
    --------
    >>> finite(0.5), finite(float("nan")), finite(None)
    (True, False, False)
    """
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


__all__ = [
    "DIGITS",
    "EXACT_CAP",
    "Parsed",
    "Shown",
    "clip",
    "decimal_text",
    "exact_value",
    "finite",
    "kind_of",
    "looks_like_float_data",
    "number_text",
    "readable_measure",
    "show",
    "summary_number",
]
