"""The one encoder of kfio's JSON: the mechanical rules, applied to what a report's view returns.

A view (:mod:`kfio._json._registry`) says *which* fields a report has and
what they hold; :func:`encode` says how each value becomes JSON, the same
way everywhere:

==========================================  ============================================
``None``, ``str``, ``bool``, ``int``        unchanged
``float``, ``numpy.floating``               the float, or ``null`` if NaN or infinite
``numpy.integer`` / ``numpy.bool_``         ``int`` / ``bool``
``complex``                                 ``[re, im]``, each through the float rule
``numpy.ndarray``                           nested lists, entries through these rules
``tuple``, ``list``                         a list, entries through these rules
``dict`` with ``str`` keys                  a dict, keys in order, values through these rules
a report object with a view                 its view's fields (``kfio_version`` first for a
                                            :class:`kfio._reporting.Report`), through these rules
anything else (``Fraction``, SymPy, ...)    :class:`TypeError` naming the type and the key path
==========================================  ============================================

The last rule is deliberate: an exact number must be turned into text
(``fraction_text``) or a float by its view, never guessed here.  NumPy is
never imported by this module: a NumPy value can only exist once NumPy is
loaded, so the checks look it up in ``sys.modules``.
"""

from __future__ import annotations

import math
import sys
from typing import Any, SupportsFloat

from .._version import __version__
from ._registry import view_of


def json_float(x: SupportsFloat | None) -> float | None:
    """``float(x)``, or ``None`` when ``x`` is missing, NaN or infinite (JSON has neither).

    Examples
    --------
    >>> json_float(0.5), json_float(float("inf")), json_float(None)
    (0.5, None, None)
    """
    if x is None:
        return None
    v = float(x)
    return v if math.isfinite(v) else None


def stamp() -> dict[str, Any]:
    """The fields every report's JSON starts with: ``{"kfio_version": ...}``."""
    return {"kfio_version": __version__}


class _Refused(Exception):
    """A value the rules do not cover; each container on the way up adds its key to ``where``."""

    def __init__(self, what: str) -> None:
        super().__init__(what)
        self.what = what
        self.where: list[str] = []


def encode(value: Any, path: str = "$") -> Any:
    """``value`` as a JSON tree (module docstring), or :class:`TypeError` naming what cannot be encoded.

    Parameters
    ----------
    value:
        A report, a piece of one, or raw values as a view returns them.
    path:
        Where ``value`` sits, for the error message (``$.blocks[0].sigma``).

    Examples
    --------
    >>> encode({"a": (1, 2.5, float("nan")), "z": 1j})
    {'a': [1, 2.5, None], 'z': [0.0, 1.0]}
    >>> from fractions import Fraction
    >>> encode({"p": [Fraction(1, 2)]})
    Traceback (most recent call last):
    ...
    TypeError: kfio JSON: cannot encode a Fraction at $.p[0] (a view must turn it into text or a float)
    """
    try:
        return _encode(value)
    except _Refused as e:  # the key path is only built for the error, never on the way down
        where = path + "".join(reversed(e.where))
        raise TypeError(f"kfio JSON: {e.what.format(where=where)}") from None


def _encode(value: Any) -> Any:
    if isinstance(value, float):  # numpy.float64 too: a plain float comes out
        return float(value) if math.isfinite(value) else None
    if type(value) is str or value is None or isinstance(value, int):  # bool is an int
        return value
    if isinstance(value, str):  # a kfio.Verdict: its JSON text, as a plain str
        return str(value)
    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            if not isinstance(k, str):
                raise _Refused(f"a key of type {type(k).__name__} at {{where}} (keys must be str)")
            try:
                out[k] = _encode(v)
            except _Refused as e:
                e.where.append(f".{k}")
                raise
        return out
    if isinstance(value, (list, tuple)):
        items = []
        for i, v in enumerate(value):
            try:
                items.append(_encode(v))
            except _Refused as e:
                e.where.append(f"[{i}]")
                raise
        return items
    if isinstance(value, complex):
        return [json_float(value.real), json_float(value.imag)]
    np = sys.modules.get("numpy")
    if np is not None:
        if isinstance(value, np.ndarray):
            return _array(np, value)
        if isinstance(value, np.bool_):
            return bool(value)
        if isinstance(value, np.integer):
            return int(value)
        if isinstance(value, np.floating):
            return json_float(value)
        if isinstance(value, np.complexfloating):
            return [json_float(value.real), json_float(value.imag)]
    view = view_of(type(value))
    if view is None:
        raise _Refused(
            f"cannot encode a {type(value).__qualname__} at {{where}} (a view must turn it into text or a float)"
        )
    fields = view(value)
    if getattr(value, "json_stamped", False):
        fields = {**stamp(), **fields}
    return _encode(fields)


def _array(np: Any, a: Any) -> Any:
    """A NumPy array as nested lists: whole-array for real and integer dtypes, else entry by entry."""
    if a.dtype.kind == "f" and a.dtype.itemsize > 8:  # long double: tolist() would keep NumPy scalars
        a = a.astype(float)  # beyond the float64 range: inf, hence null, as for any float
    if a.dtype.kind == "f":
        finite = np.isfinite(a)
        if finite.all():
            return a.tolist()
        entries = a.astype(object)
        entries[~finite] = None
        return entries.tolist()
    if a.dtype.kind in "biu":
        return a.tolist()
    return _encode(a.tolist())


__all__ = ["encode", "json_float", "stamp"]
