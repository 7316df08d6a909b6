"""What every report shares: ``to_dict()``, the version stamp, the JSON text and a short repr.

The JSON of every report is built in one place, :mod:`kfio._json`: a *view*
per report class lists its fields as raw values, and one encoder
(:func:`kfio._json.encode`) applies the mechanical rules (finite floats or
``null``, NumPy to lists and numbers, tuples to lists, nested reports to
their views; anything else is a :class:`TypeError`).  :meth:`ReportPart.to_dict`
is that encoder, so no report class builds its own dict.  A :class:`Report`
(one per command) starts its JSON with ``kfio_version``, also when nested in
another, and :func:`json_text` is the one way that JSON becomes text (the
CLI's ``--json``, the HTTP body and ``to_json()``).
"""

from __future__ import annotations

import json
import re
from fractions import Fraction
from typing import Any, ClassVar

from ._exact_values import ExactReal, exact_value
from ._json import encode, stamp
from ._version import __version__


def json_text(report: dict[str, Any]) -> str:
    """Stable JSON text: keys in the order built, two-space indent, no NaN."""
    return json.dumps(report, indent=2, allow_nan=False)


class ReportPart:
    """A report or a piece of one: ``to_dict()`` is its JSON, built by its view in :mod:`kfio._json`."""

    #: Whether the JSON starts with ``kfio_version`` (every :class:`Report`).
    json_stamped: ClassVar[bool] = False

    def to_dict(self) -> dict[str, Any]:
        """The JSON object of this report (its view in :mod:`kfio._json`, encoded)."""
        out: dict[str, Any] = encode(self)
        return out

    def exact_of(self, name: str) -> Fraction | ExactReal | None:
        """The exact value of field ``name`` as an object: ``Fraction`` if rational, else :class:`kfio.ExactReal`.

        ``name`` is a value that has an exact text beside its float, the
        field ``name + "_exact"`` (``"critical_arrival_probability"``,
        ``"sigma"``, ``"modulus"``, ...; :meth:`exact_names` lists them);
        ``None`` when the report has no exact value there.  The text is read
        as :func:`kfio.exact_value` reads it, never evaluated.

        Examples
        --------
        >>> import kfio
        >>> r = kfio.analyze(kfio.System(A=[[1.25]], C=[[1]]), kfio.bernoulli(0.5))
        >>> r.exact_of("critical_arrival_probability"), r.blocks[0].exact_of("modulus")
        (Fraction(9, 25), Fraction(5, 4))
        """
        key = name.removesuffix("_exact")
        if key not in self.exact_names():
            raise AttributeError(
                f"{type(self).__name__} has no exact value {name!r}; it has: {', '.join(self.exact_names()) or 'none'}"
            )
        text, approx = self._exact_pair(key)
        if text is None:
            return None
        return exact_value(text, approx if isinstance(approx, (int, float)) else None)

    def exact_names(self) -> tuple[str, ...]:
        """The names :meth:`exact_of` accepts: every field ``X`` with an exact text ``X_exact``."""
        return tuple(sorted(n.removesuffix("_exact") for n in dir(self) if n.endswith("_exact")))

    def _exact_pair(self, key: str) -> tuple[Any, Any]:
        """The exact text of ``key`` and its float (or ``None``): the attributes ``key_exact`` and ``key``."""
        return getattr(self, key + "_exact"), getattr(self, key, None)


#: A text or fraction longer than this is shown in a ``repr`` as kfio's number format reads it.
_LONG_TEXT = 40


class ShortRepr(ReportPart):
    """A ``repr`` of a few telling attributes instead of every field."""

    _repr_fields: ClassVar[tuple[str, ...]] = ()

    def _repr_items(self) -> list[tuple[str, Any]]:
        return [(name, getattr(self, name)) for name in self._repr_fields]

    def __repr__(self) -> str:
        items = ", ".join(f"{k}={_short(v)}" for k, v in self._repr_items())
        return f"{type(self).__name__}({items})"


class Report(ShortRepr):
    """A top-level report: ``to_dict()`` (the ``--json`` object, ``kfio_version`` first) and :meth:`to_json`."""

    json_stamped: ClassVar[bool] = True

    @property
    def kfio_version(self) -> str:
        """The version of kfio that made the report."""
        return __version__

    def to_json(self) -> str:
        """The JSON text that ``kfio <command> --json`` prints for the same request, byte for byte."""
        return json_text(self.to_dict())


#: Characters a terminal may act on instead of showing: C0 controls but tab and newline, DEL, C1
#: controls (U+0080 to U+009F, where U+009B is a one-character CSI), and the bidirectional
#: embeddings, overrides and isolates (U+202A to U+202E, U+2066 to U+2069) that reorder what is shown.
_TERMINAL_UNSAFE = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u202a-\u202e\u2066-\u2069]")


def _visible(match: re.Match[str]) -> str:
    code = ord(match.group())
    return f"\\x{code:02x}" if code <= 0xFF else f"\\u{code:04x}"


def terminal_text(text: str) -> str:
    r"""``text`` with every character a terminal would act on written as a visible escape.

    User text (sensor names, keys, field pointers) reaches terminals through
    the CLI's summaries and error lines; an ESC there could set the window
    title, recolour or erase the screen (ECMA-48 escape sequences).  Newline
    and tab are kept; every other control character, and the Unicode
    bidirectional controls, become ``\xHH`` or ``\uHHHH``.  Lone surrogates
    are left to :func:`kfio.model._exact.escaped`.

    Examples
    --------
    >>> print(terminal_text("sensor \x1b]0;pwned\x07 ok\n"))
    sensor \x1b]0;pwned\x07 ok
    <BLANKLINE>
    """
    return _TERMINAL_UNSAFE.sub(_visible, text)


def _short(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, (str, Fraction)) and len(str(value)) > _LONG_TEXT:
        from ._numbers import readable_measure  # a 60-digit fraction or a CRootOf: its decimal and kind

        return repr(readable_measure(str(value)))
    if isinstance(value, tuple) and value and not isinstance(value[0], ShortRepr):
        return "(" + ", ".join(_short(v) for v in value) + ("," if len(value) == 1 else "") + ")"
    return repr(value)


__all__ = ["Report", "ReportPart", "ShortRepr", "json_text", "stamp", "terminal_text"]
