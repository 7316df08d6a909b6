"""From Python values to the JSON tree of the one validator, and back to Python names.

The Python API (:mod:`kfio._api`) does not validate anything itself: it turns
its arguments into exactly the tree :func:`kfio.model._exact.load_json` makes
of request text (``int``, :class:`decimal.Decimal` for a decimal, ``str``,
lists and dicts) and hands that to :mod:`kfio.model._request`.  So both
routes give the same :class:`~kfio.model._types.Request` and the same errors;
only the field is renamed from a JSON pointer (``/system/A/0/1``) to the
Python argument (``A[0][1]``).

A float means its shortest round-trip decimal text, never its binary value:
``0.1`` is ``1/10``; a float32 ``0.1`` is ``1/10`` too (its own shortest
text), not the float64 text of its value.
"""

from __future__ import annotations

import numbers
from collections.abc import Mapping, Sequence
from decimal import Decimal
from fractions import Fraction
from typing import Any

import numpy as np

from ..errors import InvalidInput
from ._exact import fraction_text, parse_number
from ._pointer import pointer_tokens


def python_leaf(x: Any) -> Any:
    """One scalar as :func:`~kfio.model._exact.load_json` would have produced it.

    Examples
    --------
    >>> python_leaf(0.1), python_leaf(np.float32(0.1)), python_leaf(np.int64(3)), python_leaf(Fraction(1, 3))
    (Decimal('0.1'), Decimal('0.1'), 3, '1/3')
    """
    if isinstance(x, (bool, np.bool_)):
        return bool(x)  # refused by the validator, as JSON true is
    if isinstance(x, (Decimal, str)):
        return x
    if isinstance(x, numbers.Integral):  # int and every numpy integer
        return int(x)
    if isinstance(x, float):  # float and numpy.float64 (a float subclass)
        return Decimal(repr(float(x)))
    if isinstance(x, np.floating):  # float16, float32, longdouble: their own shortest text
        return Decimal(np.format_float_positional(x, unique=True, trim="-"))
    if isinstance(x, numbers.Rational):  # Fraction and other exact rationals
        return fraction_text(Fraction(int(x.numerator), int(x.denominator)))
    return x  # complex, None, anything else: the validator names the rule


def python_tree(value: Any) -> Any:
    """Nested lists, tuples, numpy arrays (any real dtype) and mappings, as a JSON tree.

    Array elements keep their dtype on the way (a float32 entry is read as a
    float32), so ``tolist()`` is never used.

    Examples
    --------
    >>> python_tree(np.array([[1, 2]], dtype=np.int64)), python_tree(((0.5,),))
    ([[1, 2]], [[Decimal('0.5')]])
    """
    if isinstance(value, np.ndarray):
        value = np.asarray(value)  # np.matrix rows would stay 2-D forever
        if value.ndim == 0:
            return python_leaf(value[()])
        return [python_tree(value[i]) for i in range(value.shape[0])]
    if isinstance(value, Mapping):
        return {k: python_tree(v) for k, v in value.items()}
    if isinstance(value, Sequence) and not isinstance(value, (str, bytes, bytearray)):
        return [python_tree(v) for v in value]
    return python_leaf(value)


def json_ready(tree: Any) -> Any:
    """The tree with every :class:`~decimal.Decimal` as its text, for :func:`json.dumps`.

    The validator reads a decimal string exactly as it reads the JSON number.
    """
    if isinstance(tree, dict):
        return {k: json_ready(v) for k, v in tree.items()}
    if isinstance(tree, list):
        return [json_ready(v) for v in tree]
    return str(tree) if isinstance(tree, Decimal) else tree


def python_name(pointer: str, tree: Any, name: str, attribute: bool = False) -> str:
    """A JSON pointer into ``tree`` written as Python subscripts of ``name``.

    List indices become ``[i]``, object keys ``['key']``; with ``attribute``
    the first key is written ``.key`` (or bare, when ``name`` is empty).

    Examples
    --------
    >>> python_name("/A/0/1", {"A": [[1, 2]]}, "", attribute=True)
    'A[0][1]'
    >>> python_name("/arrival_probability/01", {"arrival_probability": {"01": 1}}, "channel")
    "channel['arrival_probability']['01']"
    """
    out, node = name, tree
    for i, key in enumerate(pointer_tokens(pointer)):
        if isinstance(node, list) and key.isdigit() and int(key) < len(node):
            out, node = f"{out}[{key}]", node[int(key)]
            continue
        if i == 0 and attribute:
            out = f"{out}.{key}" if out else key
        else:
            out = f"{out}[{key!r}]"
        node = node.get(key) if isinstance(node, dict) else None
    return out


#: ``(pointer prefix, Python name, subtree at the prefix, first key as attribute)``.
Route = tuple[str, str, Any, bool]


def renamed(exc: InvalidInput, routes: Sequence[Route]) -> InvalidInput:
    """``exc`` (same class, same rule) with its field named by the first matching route."""
    for prefix, name, tree, attribute in routes:
        if exc.field == prefix or exc.field.startswith(prefix + "/"):
            field = python_name(exc.field[len(prefix) :], tree, name, attribute)
            return type(exc)(field or name, exc.rule)
    return exc


def positive_ints(**arguments: Any) -> None:
    """Refuse any keyword argument that is given (not ``None``) and is not a positive ``int``, naming it.

    >>> positive_ints(workers=2, chunk_size=None)
    >>> positive_ints(workers=0)
    Traceback (most recent call last):
    ...
    kfio.errors.InvalidInput: workers: expected a positive integer; got 0
    """
    for name, value in arguments.items():
        if value is not None and (isinstance(value, bool) or not isinstance(value, int) or value < 1):
            raise InvalidInput(name, f"expected a positive integer; got {value!r}")


def budget_seconds(budget: Any, upper: float = 3600, field: str = "budget") -> float | None:
    """The wall-clock seconds of a ``budget`` argument: ``None`` when none is given or it has no limit.

    A :class:`kfio.Budget` gives what remains of it (the functions that run
    in worker processes, ``kfio.sweep`` and ``kfio.check``, take its clock
    only: a step count cannot follow the work into another process); a
    number of seconds must lie in ``[0.01, upper]``, as ``options.time_budget_s``.

    Examples
    --------
    >>> budget_seconds(None), budget_seconds("5/2"), budget_seconds(30)
    (None, 2.5, 30.0)
    """
    from .._budget import Budget
    from ._request import MIN_TIME_BUDGET_S

    if budget is None:
        return None
    if isinstance(budget, Budget):
        return budget.remaining()
    value = python_leaf(budget)
    if isinstance(value, bool) or not isinstance(value, (int, Decimal, str)) or len(str(value)) > 40:
        raise InvalidInput(field, f"expected seconds or a kfio.Budget; got a {type(budget).__name__}")
    t = parse_number(value, field)
    if not MIN_TIME_BUDGET_S <= t <= upper:
        raise InvalidInput(field, f"must be in [{float(MIN_TIME_BUDGET_S):g}, {upper:g}] seconds")
    return float(t)
