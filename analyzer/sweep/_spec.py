"""Sweep requests: a base request and axes, or a list of whole requests.

A sweep is validated in full before any work starts: every axis pointer must
exist in the base request, and every point must pass the same validator as a
single request (:func:`kfio.model.parse_request`).  A bad point is named by its
index and the JSON pointer of the offending field.
"""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Sequence as SequenceABC
from dataclasses import dataclass
from decimal import Decimal
from fractions import Fraction
from typing import Any, Callable, Iterator, Sequence

from ..errors import InvalidInput, LimitExceeded
from ..model import (
    DEFAULT_LIMITS,
    Limits,
    OptionField,
    fraction_text,
    load_json,
    option_field,
    option_fields,
    parse_number,
)
from ._parse import parse_point

COMMANDS = ("analyze", "bounds", "simulate", "loop")
COMBINES = ("grid", "zip")
_TOP_KEYS = {"command", "base", "axes", "combine", "requests", "options"}
_AXIS_KEYS = {"pointer", "values", "from", "to", "num", "name"}
_OPTION_KEYS = {f.name for f in option_fields("sweep")}

#: At most this many points in one sweep (a grid of 1000 x 1000).
MAX_POINTS = 1_000_000
#: At most this many values on one axis.
MAX_AXIS_VALUES = 100_000


class RationalRange(SequenceABC[Fraction]):
    """The exactly spaced values ``from + (to - from) i / (num - 1)``, ``i = 0 .. num - 1``, built on demand.

    A range axis is held as its three numbers, never as a list: the sweep's
    size is known from ``num`` alone, and a value's exact text
    (:func:`kfio.model.fraction_text`) is computed only when a point needs it.
    """

    __slots__ = ("lo", "hi", "num", "_start", "_step", "_den")

    def __init__(self, lo: Fraction, hi: Fraction, num: int):
        self.lo, self.hi, self.num = lo, hi, num
        # the i-th value is (start + step i) / den in integers: one gcd per value, not four Fraction operations
        step = (hi - lo) / (num - 1) if num > 1 else Fraction(0)
        den = math.lcm(lo.denominator, step.denominator)
        self._start, self._step, self._den = (
            lo.numerator * (den // lo.denominator),
            step.numerator * (den // step.denominator),
            den,
        )

    def __len__(self) -> int:
        return self.num

    def __getitem__(self, i: Any) -> Any:
        if isinstance(i, slice):
            return tuple(self[k] for k in range(*i.indices(self.num)))
        i = int(i)
        if i < 0:
            i += self.num
        if not 0 <= i < self.num:
            raise IndexError(i)
        num = self._start + self._step * i
        g = math.gcd(num, self._den)
        num, den = num // g, self._den // g
        return str(num) if den == 1 else f"{num}/{den}"  # :func:`kfio.model.fraction_text` of the value

    def __eq__(self, other: object) -> bool:
        if isinstance(other, RationalRange):
            return (self.lo, self.hi, self.num) == (other.lo, other.hi, other.num)
        return NotImplemented

    def __hash__(self) -> int:
        return hash((self.lo, self.hi, self.num))

    def __repr__(self) -> str:
        return f"RationalRange({fraction_text(self.lo)!r}, {fraction_text(self.hi)!r}, {self.num})"


class SweepPointInvalid(InvalidInput):
    """One point of a sweep fails validation; ``index`` says which."""

    def __init__(self, index: int, field: str, rule: str):
        self.index = index
        super().__init__(f"/points/{index}{field}", rule)


@dataclass(frozen=True)
class Axis:
    """One swept coordinate: a JSON pointer into the request and its values."""

    pointer: str
    values: Sequence[Any]  # a tuple of given values, or a :class:`RationalRange`
    name: str

    @property
    def tokens(self) -> tuple[str, ...]:
        return parse_pointer(self.pointer, f"/axes/{self.name}/pointer")


@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep: what to run and on which points."""

    command: str
    base: Any
    axes: tuple[Axis, ...]
    combine: str
    requests: tuple[Any, ...] | None
    point_budget_s: float
    time_budget_s: float | None
    chunk_size: int | None

    @property
    def size(self) -> int:
        if self.requests is not None:
            return len(self.requests)
        if not self.axes:
            return 1
        if self.combine == "zip":
            return len(self.axes[0].values)
        n = 1
        for a in self.axes:
            n *= len(a.values)
        return n

    @property
    def coordinate_names(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.axes)


def parse_pointer(pointer: Any, field: str) -> tuple[str, ...]:
    """The reference tokens of an RFC 6901 JSON pointer (``/a/0/b`` -> ``('a', '0', 'b')``)."""
    if not isinstance(pointer, str) or not pointer.startswith("/"):
        raise InvalidInput(
            field, "a JSON pointer is a string that starts with '/', such as '/channel/arrival_probability'"
        )
    return tuple(t.replace("~1", "/").replace("~0", "~") for t in pointer[1:].split("/"))


def _get(tree: Any, tokens: Sequence[str], field: str) -> Any:
    node = tree
    for depth, tok in enumerate(tokens):
        where = "/" + "/".join(tokens[: depth + 1])
        if isinstance(node, dict):
            if tok not in node:
                raise InvalidInput(field, f"the base request has nothing at {where}")
            node = node[tok]
        elif isinstance(node, list):
            if not tok.isascii() or not tok.isdigit() or int(tok) >= len(node):
                raise InvalidInput(field, f"the base request has nothing at {where}")
            node = node[int(tok)]
        else:
            raise InvalidInput(field, f"the base request has nothing at {where}")
    return node


def substitute(tree: Any, tokens: Sequence[str], value: Any) -> Any:
    """A copy of ``tree`` with the node at ``tokens`` replaced by ``value`` (copies only the path)."""
    if not tokens:
        return value
    head, rest = tokens[0], tokens[1:]
    if isinstance(tree, dict):
        out = dict(tree)
        out[head] = substitute(tree[head], rest, value)
        return out
    out_list = list(tree)
    out_list[int(head)] = substitute(tree[int(head)], rest, value)
    return out_list


def _positive_int(value: Any, field: str, upper: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, Decimal, str)):
        raise InvalidInput(field, "expected a positive integer")
    if isinstance(value, (Decimal, str)) and len(str(value)) > 12:
        raise LimitExceeded(field, f"at most {upper}")
    x = parse_number(value, field)
    if x.denominator != 1 or x < 1:
        raise InvalidInput(field, "expected a positive integer")
    if x > upper:
        raise LimitExceeded(field, f"at most {upper}")
    return int(x)


def _axis(obj: Any, index: int, base: Any) -> Axis:
    field = f"/axes/{index}"
    if not isinstance(obj, dict):
        raise InvalidInput(field, "an axis is an object with 'pointer' and either 'values' or 'from', 'to', 'num'")
    unknown = sorted(set(obj) - _AXIS_KEYS)
    if unknown:
        raise InvalidInput(f"{field}/{unknown[0]}", f"unknown key; an axis has {sorted(_AXIS_KEYS)}")
    if "pointer" not in obj:
        raise InvalidInput(f"{field}/pointer", "required")
    tokens = parse_pointer(obj["pointer"], f"{field}/pointer")
    _get(base, tokens, f"{field}/pointer")
    name = obj.get("name", obj["pointer"])
    if not isinstance(name, str) or not name:
        raise InvalidInput(f"{field}/name", "expected a non-empty string")
    has_values = "values" in obj
    has_range = any(k in obj for k in ("from", "to", "num"))
    if has_values == has_range:
        raise InvalidInput(field, "give either 'values' or all of 'from', 'to', 'num'")
    if has_values:
        values = obj["values"]
        if not isinstance(values, list) or not values:
            raise InvalidInput(f"{field}/values", "expected a non-empty array")
        if len(values) > MAX_AXIS_VALUES:
            raise LimitExceeded(f"{field}/values", f"at most {MAX_AXIS_VALUES} values")
        return Axis(obj["pointer"], tuple(values), name)
    for key in ("from", "to", "num"):
        if key not in obj:
            raise InvalidInput(f"{field}/{key}", "required with a range axis")
    lo = parse_number(obj["from"], f"{field}/from")
    hi = parse_number(obj["to"], f"{field}/to")
    num = _positive_int(obj["num"], f"{field}/num", MAX_AXIS_VALUES)
    if num == 1 and lo != hi:
        raise InvalidInput(f"{field}/num", "num = 1 needs from = to")
    # Exact rational spacing: the i-th value is from + (to - from) i / (num - 1), made when asked for.
    return Axis(obj["pointer"], RationalRange(lo, hi, num), name)


def _axis_length(obj: Any, index: int) -> int:
    """How many values axis ``index`` has, from its raw JSON (``len(values)`` or ``num``), building nothing.

    A malformed axis counts 1 here; :func:`_axis` then names what is wrong with it.
    """
    if not isinstance(obj, dict):
        return 1  # not an axis: :func:`_axis` says why
    if "values" in obj:
        values = obj["values"]
        if isinstance(values, list) and len(values) > MAX_AXIS_VALUES:
            raise LimitExceeded(f"/axes/{index}/values", f"at most {MAX_AXIS_VALUES} values")
        return len(values) if isinstance(values, list) and values else 1
    if "num" not in obj:
        return 1
    return _positive_int(obj["num"], f"/axes/{index}/num", MAX_AXIS_VALUES)


def _too_many(lengths: Sequence[int], limit: int) -> LimitExceeded:
    """The refusal of a grid past ``limit`` points; its size is said as a power of ten, never printed in full."""
    # fsum of the log10s is within 1e-9 of log10 of the product here, so 10^k < the product.
    k = math.floor(math.fsum(math.log10(n) for n in lengths) - 1e-6)
    if k >= len(str(limit)):
        return LimitExceeded("/axes", f"the sweep has more than 10^{k} points; at most {limit}")
    return LimitExceeded("/axes", f"the sweep has more than {limit} points; at most {limit}")


def sweep_size(obj: Any, limit: int = MAX_POINTS) -> int:
    """The number of points of the raw sweep ``obj`` (JSON tree), computed before any axis is built.

    A list of requests has ``len(requests)`` points; a grid has the product of
    its axes' lengths (``len(values)`` or ``num``), multiplied with an early
    exit past ``limit``; a zip has its axes' common length.  The work is
    linear in the number of axes, whatever their ``num``.

    Raises
    ------
    LimitExceeded
        More than ``limit`` points (the message gives a power of ten for a
        huge count, never the count's digits), or an axis past
        :data:`MAX_AXIS_VALUES` values.
    InvalidInput
        The axes are not a list of axes, or a zip's axes differ in length.
    """
    if not isinstance(obj, dict):
        raise InvalidInput("/", "a sweep is a JSON object with 'command' and 'base' + 'axes' or 'requests'")
    if "requests" in obj:
        reqs = obj["requests"]
        n = len(reqs) if isinstance(reqs, list) else 0
        if n > limit:
            raise LimitExceeded("/requests", f"the sweep has {n} points; at most {limit}")
        return n
    axes = obj.get("axes", [])
    if not isinstance(axes, list):
        raise InvalidInput("/axes", "expected an array of axes")
    lengths = [_axis_length(a, i) for i, a in enumerate(axes)]
    if obj.get("combine", "grid") == "zip" and lengths:
        if len(set(lengths)) > 1:
            raise InvalidInput("/axes", "zip needs axes of equal length: " + ", ".join(map(str, lengths)))
        n = lengths[0]
    else:
        n = 1
        for length in lengths:
            n *= length
            if n > limit:
                raise _too_many(lengths, limit)
    if n > limit:
        raise LimitExceeded("/axes", f"the sweep has {n} points; at most {limit}")
    return n


def parse_sweep(obj: Any, max_points: int = MAX_POINTS) -> SweepSpec:
    """Validate the shape of a sweep request (not yet its points: see :func:`validate_points`).

    The point count is checked (:func:`sweep_size`) before any axis is built,
    and range axes stay lazy (:class:`RationalRange`), so this costs time
    linear in the size of ``obj``, however many points it describes.

    Parameters
    ----------
    obj:
        The JSON tree of :func:`kfio.model.load_json`:
        ``{"command": "analyze", "base": {...}, "axes": [...], "combine": "grid"}`` or
        ``{"command": "analyze", "requests": [{...}, ...]}``.
    max_points:
        Most points allowed (:data:`MAX_POINTS` at most).
    """
    if not isinstance(obj, dict):
        raise InvalidInput("/", "a sweep is a JSON object with 'command' and 'base' + 'axes' or 'requests'")
    unknown = sorted(set(obj) - _TOP_KEYS)
    if unknown:
        raise InvalidInput(f"/{unknown[0]}", f"unknown key; a sweep has {sorted(_TOP_KEYS)}")
    command = obj.get("command", "analyze")
    if command not in COMMANDS:
        raise InvalidInput("/command", f"expected one of {list(COMMANDS)}")
    combine = obj.get("combine", "grid")
    if combine not in COMBINES:
        raise InvalidInput("/combine", f"expected one of {list(COMBINES)}")
    opts = obj.get("options", {})
    if not isinstance(opts, dict):
        raise InvalidInput("/options", "expected an object")
    unknown = sorted(set(opts) - _OPTION_KEYS)
    if unknown:
        raise InvalidInput(f"/options/{unknown[0]}", f"unknown option; sweep options are {sorted(_OPTION_KEYS)}")
    point_field = option_field("sweep", "point_budget_s")
    point_budget = float(_budget(opts.get("point_budget_s", point_field.default), point_field))
    total = opts.get("time_budget_s")
    time_budget = None if total is None else float(_budget(total, option_field("sweep", "time_budget_s")))
    chunk_field = option_field("sweep", "chunk_size")
    chunk = None
    if "chunk_size" in opts:
        chunk = _positive_int(opts["chunk_size"], "/options/chunk_size", int(chunk_field.maximum or 0))
    if ("requests" in obj) == ("base" in obj):
        raise InvalidInput("/", "give either 'base' with 'axes', or 'requests'")
    sweep_size(obj, min(max_points, MAX_POINTS))
    if "requests" in obj:
        if "axes" in obj:
            raise InvalidInput("/axes", "axes go with 'base', not with 'requests'")
        reqs = obj["requests"]
        if not isinstance(reqs, list) or not reqs:
            raise InvalidInput("/requests", "expected a non-empty array of requests")
        for i, r in enumerate(reqs):  # O(body): each request's content is validated with its point
            if not isinstance(r, dict):
                raise InvalidInput(f"/requests/{i}", "expected a request object")
        return SweepSpec(command, None, (), combine, tuple(reqs), point_budget, time_budget, chunk)
    base = obj["base"]
    if not isinstance(base, dict):
        raise InvalidInput("/base", "expected a request object")
    axes_obj = obj.get("axes", [])
    if not isinstance(axes_obj, list):
        raise InvalidInput("/axes", "expected an array of axes")
    axes = tuple(_axis(a, i, base) for i, a in enumerate(axes_obj))
    names = [a.name for a in axes]
    if len(set(names)) != len(names):
        raise InvalidInput("/axes", "two axes have the same name (pointer); give each a distinct 'name'")
    return SweepSpec(command, base, axes, combine, None, point_budget, time_budget, chunk)


def _budget(value: Any, spec: OptionField) -> Fraction:
    field = spec.pointer
    if isinstance(value, (Decimal, str)) and len(str(value)) > (spec.max_text or 0):
        raise InvalidInput(field, "expected a number of seconds")
    t = parse_number(value, field)
    if not spec.admits(t):
        raise InvalidInput(field, f"must lie in [{float(spec.minimum or 0):g}, {spec.maximum}] seconds")
    return t


def load_sweep(text: str | bytes, max_points: int = MAX_POINTS) -> SweepSpec:
    """Parse sweep JSON, or JSON Lines of whole requests (one plant variant a line).

    JSON Lines are recognised by having more than one non-empty line that each
    parse as a JSON object with a ``system`` key; they become an ``analyze``
    sweep over those requests.
    """
    if isinstance(text, bytes):
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise InvalidInput("/", f"the sweep is not UTF-8 text (byte {exc.start})") from None
    lines = [ln for ln in text.splitlines() if ln.strip()]
    if len(lines) > 1 and lines[0].lstrip().startswith("{") and '"system"' in lines[0]:
        try:
            reqs = [load_json(ln) for ln in lines]
        except InvalidInput:
            reqs = None
        if reqs is not None:
            return parse_sweep({"command": "analyze", "requests": reqs}, max_points)
    return parse_sweep(load_json(text), max_points)


@dataclass(frozen=True)
class Point:
    """One point of a sweep: its index, coordinates (axis name -> value) and request tree."""

    index: int
    coordinates: dict[str, Any]
    request: Any


def points(spec: SweepSpec) -> Iterator[Point]:
    """Every point of the sweep in index order (grid: the last axis varies fastest)."""
    if spec.requests is not None:
        for i, req in enumerate(spec.requests):
            yield Point(i, {}, req)
        return
    if not spec.axes:
        yield Point(0, {}, spec.base)
        return
    tokens = [a.tokens for a in spec.axes]
    combos: Any = (
        zip(*(a.values for a in spec.axes))
        if spec.combine == "zip"
        else itertools.product(*(a.values for a in spec.axes))
    )
    for i, combo in enumerate(combos):
        tree = spec.base
        for tok, value in zip(tokens, combo):
            tree = substitute(tree, tok, value)
        yield Point(i, {a.name: v for a, v in zip(spec.axes, combo)}, tree)


def validate_points(spec: SweepSpec, limits: Limits = DEFAULT_LIMITS) -> list[Point]:
    """All points, each checked by the single-request validator before any work starts.

    Raises
    ------
    SweepPointInvalid
        Naming the point's index and the offending field, e.g.
        ``/points/17/channel/arrival_probability``.
    """
    out: list[Point] = []
    check_points(spec, limits, out.append)
    return out


def check_points(
    spec: SweepSpec,
    limits: Limits = DEFAULT_LIMITS,
    keep: Callable[[Point], None] | None = None,
    tick: Callable[[], None] | None = None,
) -> int:
    """Check every point with the single-request validator, keeping none.

    The validator is :func:`kfio.model.parse_request` (each distinct plant
    validated once: :func:`kfio.sweep._parse.parse_point`), or for a ``loop``
    sweep :func:`kfio.loop.parse_loop_request`.

    ``keep`` is called with each valid point; ``tick`` after each point (a
    budget's check-in, which may raise: one point's check can take a tenth of
    a second).  Returns the number of points.

    Raises
    ------
    SweepPointInvalid
        As :func:`validate_points`.
    """
    validate: Callable[[Any, Limits], Any] = parse_point
    if spec.command == "loop":  # each point is a loop request (kfio.loop)
        from ..loop import parse_loop_request

        validate = parse_loop_request
    point_limits = limits.for_command(spec.command)  # once, not per point
    n = 0
    for p in points(spec):
        try:
            validate(p.request, point_limits)
        except InvalidInput as exc:
            raise SweepPointInvalid(p.index, exc.field if exc.field != "/" else "", exc.rule) from None
        if keep is not None:
            keep(p)
        n += 1
        if tick is not None:
            tick()
    return n


def request_text(tree: Any) -> str:
    """JSON text of a request tree that keeps every number's exact decimal text."""
    return json.dumps(_exact_tree(tree), separators=(",", ":"), sort_keys=True)


def _exact_tree(node: Any) -> Any:
    if isinstance(node, dict):
        return {k: _exact_tree(v) for k, v in node.items()}
    if isinstance(node, list):
        return [_exact_tree(v) for v in node]
    if isinstance(node, Decimal):
        return str(node)  # a number's decimal text, as a string: the validator reads both the same way
    return node


def _combo(spec: SweepSpec, index: int) -> list[Any]:
    """The axis values of point ``index`` (row-major grid: the last axis varies fastest)."""
    if spec.combine == "zip":
        return [a.values[index] for a in spec.axes]
    combo = []
    rest = index
    for a in reversed(spec.axes):
        rest, k = divmod(rest, len(a.values))
        combo.append(a.values[k])
    combo.reverse()
    return combo


def coordinates_at(spec: SweepSpec, index: int) -> dict[str, Any]:
    """The coordinates (axis name -> value) of point ``index``, without building its request.

    The engine attaches them to each row as it streams, so it never holds a
    map of every point's coordinates.
    """
    if not 0 <= index < spec.size:
        raise IndexError(index)
    if spec.requests is not None or not spec.axes:
        return {}
    return {a.name: v for a, v in zip(spec.axes, _combo(spec, index))}


def point_at(spec: SweepSpec, index: int) -> Point:
    """The point ``index`` of the sweep without enumerating the ones before it.

    Grid order is row-major: the last axis varies fastest (as
    :func:`itertools.product`).
    """
    if not 0 <= index < spec.size:
        raise IndexError(index)
    if spec.requests is not None:
        return Point(index, {}, spec.requests[index])
    if not spec.axes:
        return Point(0, {}, spec.base)
    combo = _combo(spec, index)
    tree = spec.base
    for a, value in zip(spec.axes, combo):
        tree = substitute(tree, a.tokens, value)
    return Point(index, {a.name: v for a, v in zip(spec.axes, combo)}, tree)
