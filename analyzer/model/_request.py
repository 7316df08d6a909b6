"""The one validator for requests (STYLE.md, habit 5).

Turns the JSON tree produced by :func:`kfio.model._exact.load_json` into a
:class:`kfio.model._types.Request`, or raises :class:`InvalidInput` naming the
field (a JSON pointer) and the rule.  Everything is checked exactly: shapes,
symmetry, semidefiniteness (by the signs of the characteristic polynomial),
probability ranges, Markov tables.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any, Iterable, Mapping, Optional

from ..errors import InvalidInput, LimitExceeded
from ._exact import load_json, parse_number, value_text
from ._fields import MAX_SENSOR_NAME, OPTION_KEYS, option_field, option_fields
from ._limits import DEFAULT_LIMITS, Limits
from ._pointer import json_pointer
from ._types import Channel, MarkovChannel, Matrix, PerSensorChannel, Request, Sensor, System

OPTION_GROUPS = tuple(OPTION_KEYS)

_TOP_KEYS = {"system", "channel", "options"}
_SYSTEM_KEYS = {"A", "C", "Q", "R", "sensors"}


def pointer(where: str, key: str) -> str:
    """``where`` extended by one object key, escaped as RFC 6901 requires (``~0``, ``~1``)."""
    return where + json_pointer((key,))


def check_keys(
    obj: Any, where: str, allowed: Iterable[str], required: set[str], what: str = "field"
) -> Mapping[str, Any]:
    if not isinstance(obj, dict):
        raise InvalidInput(where, "expected a JSON object")
    for key in obj:
        if key not in allowed:
            raise InvalidInput(
                pointer(where, key), f"unknown {what} {key[:64]!r}; allowed: {', '.join(sorted(allowed))}"
            )
    for key in sorted(required):
        if key not in obj:
            raise InvalidInput(pointer(where, key), "required field is missing")
    return obj


def parse_matrix(obj: Any, where: str, name: str, limits: Limits, max_rows: int, max_cols: int) -> Matrix:
    """A non-empty rectangular matrix of exact numbers."""
    if not isinstance(obj, list) or not obj:
        raise InvalidInput(where, f"{name} must be a non-empty array of rows")
    if len(obj) > max_rows:
        raise LimitExceeded(where, f"{name} has {len(obj)} rows; the limit is {max_rows}")
    width = None
    rows = []
    for i, row in enumerate(obj):
        if not isinstance(row, list) or not row:
            raise InvalidInput(f"{where}/{i}", f"each row of {name} must be a non-empty array of numbers")
        if width is None:
            width = len(row)
            if width > max_cols:
                raise LimitExceeded(f"{where}/{i}", f"{name} has {width} columns; the limit is {max_cols}")
        elif len(row) != width:
            raise InvalidInput(f"{where}/{i}", f"row {i} of {name} has {len(row)} entries, row 0 has {width}")
        rows.append(tuple(parse_number(x, f"{where}/{i}/{j}", limits.max_digits) for j, x in enumerate(row)))
    return tuple(rows)


#: Largest Hadamard bound (bits) of the integer congruence ``D m D`` for which :func:`is_psd` runs
#: its exact route.  Every intermediate of the elimination is a ratio of minors of that matrix, so
#: this bounds the work by size, not by time: at the limit a near-singular 40 x 40 matrix takes
#: about 2 s of CPU on a loaded 2-core machine (bench/bench_validation.py, docs/input-limits.md).
MAX_EXACT_PSD_BITS = 1 << 14


def _float_filter(m: Matrix) -> Optional[int]:
    """Sign of ``lambda_min`` when floating point decides it, else ``None``.

    The symmetric eigensolver is backward stable, and by Weyl's inequality
    rounding ``m`` moves each eigenvalue by at most ``n eps ||m||``; a
    computed ``|lambda_min| > 1e-9 ||m||_F`` is far outside both errors.
    """
    import numpy as np

    scale = max(abs(x) for row in m for x in row)
    if scale == 0:
        return 0
    M = np.array([[float(x / scale) for x in row] for row in m])
    lam = float(np.linalg.eigvalsh(M)[0])
    tol = 1e-9 * float(np.linalg.norm(M))
    if lam > tol:
        return 1
    if lam < -tol:
        return -1
    return None


def is_positive_definite(m: Matrix) -> bool:
    """``m > 0`` for a symmetric rational matrix the analyzer built itself (a certificate), exactly.

    The float filter (:func:`_float_filter`, Weyl's inequality) decides clear
    cases; the rest take the exact pivoted ``L D L'`` of :func:`is_psd`, with no
    size limit (the matrix is not the user's).  The one definiteness test of the
    closed-loop certificates (Costa, Fragoso and Marques 2005, Thm 3.9).

    Examples
    --------
    >>> from fractions import Fraction as F
    >>> is_positive_definite(((F(2), F(1)), (F(1), F(1)))), is_positive_definite(((F(1), F(1)), (F(1), F(1))))
    (True, False)
    """
    if not m:
        return True
    sign = _float_filter(m)
    if sign is not None:
        return sign > 0
    return is_psd(m, strict=True, exact=True)


def hadamard_bits(m: Matrix) -> int:
    """Bits of Hadamard's bound ``prod_i ||row_i||`` of the integer congruence ``D m D``.

    ``d_i`` is the lcm of the denominators in row ``i`` of ``m``; ``D m D``
    has the same inertia as ``m`` (``D`` is positive diagonal) and integer
    entries ``m_ij d_i d_j``.

    Computed from bit lengths only (no big products): every minor of the
    scaled matrix, hence every intermediate of :func:`is_psd`'s exact route,
    has at most this many bits.  Rows of ``m`` with large coprime
    denominators make it grow fastest (the lcm multiplies them).
    """
    import math

    total = 0
    for row in m:
        d = math.lcm(*(x.denominator for x in row))
        # entry i, j of D m D is x d_i d_j with d_j <= lcm of all denominators: bound by bit lengths
        biggest = max((abs(x.numerator) * (d // x.denominator)).bit_length() for x in row)
        total += biggest + (len(row).bit_length() + 1) // 2
    dmax = max(math.lcm(*(x.denominator for x in row)).bit_length() for row in m)
    return total + len(m) * dmax


def is_psd(m: Matrix, strict: bool, where: str = "/", exact: bool = False) -> bool:
    """Exact (semi)definiteness of a symmetric rational matrix, decided deterministically.

    A floating-point filter (:func:`_float_filter`) decides clear cases.
    Near-singular matrices take the exact route: a symmetric-pivoted
    ``L D L^T`` in exact rationals (python-flint ``fmpq``), pivoting on the
    largest remaining diagonal entry; a negative one means indefinite; when
    every remaining diagonal entry is zero the matrix is semidefinite iff the
    remaining block is zero (``m_ij^2 <= m_ii m_jj``).  Every intermediate
    is a ratio of two minors of ``m``, i.e. of minors of the integer
    congruence ``D m D`` (see :func:`hadamard_bits`),
    so the work is bounded by the matrix's size: when Hadamard's bound of
    ``D m D`` exceeds :data:`MAX_EXACT_PSD_BITS` the request is refused
    (:class:`LimitExceeded` naming ``where``), whatever the machine's load.
    ``exact=True`` (certificates the analyzer built itself) skips the filter
    and the size limit.

    Examples
    --------
    >>> from fractions import Fraction as F
    >>> is_psd(((F(1), F(1)), (F(1), F(1))), strict=False), is_psd(((F(1), F(1)), (F(1), F(1))), strict=True)
    (True, False)
    """
    import flint

    sign = None if exact else _float_filter(m)
    if sign is not None:
        return sign > 0 or (sign == 0 and not strict)
    if not exact and hadamard_bits(m) > MAX_EXACT_PSD_BITS:
        raise LimitExceeded(
            where,
            "the matrix is too close to singular for floating point to decide its definiteness, and deciding "
            f"it exactly would need numbers of more than {MAX_EXACT_PSD_BITS} bits (Hadamard's bound); "
            "use entries with fewer digits or smaller denominators",
        )
    M = [[flint.fmpq(x.numerator, x.denominator) for x in row] for row in m]
    rest = list(range(len(M)))
    while rest:
        k = max(rest, key=lambda i: M[i][i])
        d = M[k][k]
        if d < 0:
            return False
        if d == 0:
            return not strict and all(M[i][j] == 0 for i in rest for j in rest)
        rest.remove(k)
        for i in rest:
            if M[i][k] == 0:
                continue
            f = M[i][k] / d
            for j in rest:
                if M[k][j] != 0:
                    M[i][j] -= f * M[k][j]
    return True


def check_symmetric(m: Matrix, where: str, name: str, n: int) -> None:
    """``m`` is ``n x n`` and exactly symmetric, else :class:`InvalidInput` at ``where``."""
    if len(m) != n or len(m[0]) != n:
        raise InvalidInput(where, f"{name} must be {n}x{n}; got {len(m)}x{len(m[0])}")
    for i in range(n):
        for j in range(i + 1, n):
            if m[i][j] != m[j][i]:
                raise InvalidInput(
                    f"{where}/{i}/{j}", f"{name} must be symmetric: {name}[{i}][{j}] != {name}[{j}][{i}]"
                )


def _parse_probability(obj: Any, where: str, limits: Limits) -> Fraction:
    x = parse_number(obj, where, limits.max_digits)
    if not 0 <= x <= 1:
        raise InvalidInput(where, f"a probability must lie in [0, 1]; got {float(x):g}")
    return x


def parse_system(obj: Any, limits: Limits = DEFAULT_LIMITS, where: str = "/system") -> System:
    """Validate ``system``: ``A`` square, ``C`` with ``n`` columns, ``Q`` PSD, ``R`` PD, sensors."""
    obj = check_keys(obj, where, _SYSTEM_KEYS, {"A", "C"})
    raw_A = obj["A"]
    if isinstance(raw_A, list) and limits.max_states < len(raw_A) <= limits.max_analyze_states:
        raise LimitExceeded(
            f"{where}/A",
            f"A has {len(raw_A)} rows; the limit is {limits.max_states} "
            f"(kfio analyze accepts up to {limits.max_analyze_states} states)",
        )
    A = parse_matrix(obj["A"], f"{where}/A", "A", limits, limits.max_states, limits.max_states)
    n = len(A)
    if len(A[0]) != n:
        raise InvalidInput(f"{where}/A", f"A must be square; got {n}x{len(A[0])}")
    C = parse_matrix(obj["C"], f"{where}/C", "C", limits, limits.max_outputs, limits.max_states)
    if len(C[0]) != n:
        raise InvalidInput(f"{where}/C", f"C must have {n} columns (A is {n}x{n}); got {len(C[0])}")
    p = len(C)
    Q = R = None
    if "Q" in obj:
        Q = parse_matrix(obj["Q"], f"{where}/Q", "Q", limits, limits.max_states, limits.max_states)
        check_symmetric(Q, f"{where}/Q", "Q", n)
        if not is_psd(Q, strict=False, where=f"{where}/Q"):
            raise InvalidInput(f"{where}/Q", "Q must be positive semidefinite")
    if "R" in obj:
        R = parse_matrix(obj["R"], f"{where}/R", "R", limits, limits.max_outputs, limits.max_outputs)
        check_symmetric(R, f"{where}/R", "R", p)
        if not is_psd(R, strict=True, where=f"{where}/R"):
            raise InvalidInput(f"{where}/R", "R must be positive definite")
    sensors = None
    if "sensors" in obj:
        sensors = _parse_sensors(obj["sensors"], f"{where}/sensors", p, limits)
    return System(A=A, C=C, Q=Q, R=R, sensors=sensors)


def _parse_sensors(obj: Any, where: str, p: int, limits: Limits) -> tuple[Sensor, ...]:
    if not isinstance(obj, list) or not obj:
        raise InvalidInput(where, "sensors must be a non-empty array of {name, rows}")
    if len(obj) > limits.max_sensors:
        raise LimitExceeded(where, f"at most {limits.max_sensors} sensors are supported; got {len(obj)}")
    seen_rows: dict[int, str] = {}
    names: set[str] = set()
    out = []
    for i, s in enumerate(obj):
        s = check_keys(s, f"{where}/{i}", {"name", "rows"}, {"name", "rows"})
        name = s["name"]
        if not isinstance(name, str) or not name or len(name) > MAX_SENSOR_NAME:
            raise InvalidInput(
                f"{where}/{i}/name", f"a sensor name must be a non-empty string of at most {MAX_SENSOR_NAME} characters"
            )
        if name in names:
            raise InvalidInput(f"{where}/{i}/name", f"sensor name {name!r} is used twice")
        names.add(name)
        rows = s["rows"]
        if not isinstance(rows, list) or not rows:
            raise InvalidInput(f"{where}/{i}/rows", "rows must be a non-empty array of row indices of C")
        for j, r in enumerate(rows):
            if isinstance(r, bool) or not isinstance(r, int) or not 0 <= r < p:
                raise InvalidInput(f"{where}/{i}/rows/{j}", f"a row index must be an integer in [0, {p - 1}]")
            if r in seen_rows:
                raise InvalidInput(
                    f"{where}/{i}/rows/{j}",
                    f"row {r} of C is already carried by sensor {seen_rows[r]!r}; sensors must partition the rows",
                )
            seen_rows[r] = name
        out.append(Sensor(name=name, rows=tuple(rows)))
    missing = sorted(set(range(p)) - set(seen_rows))
    if missing:
        raise InvalidInput(where, f"sensors must partition the rows of C; rows {missing} are carried by no sensor")
    return tuple(out)


def parse_markov_channel(obj: Any, limits: Limits = DEFAULT_LIMITS, where: str = "/channel") -> MarkovChannel:
    """Validate a one-packet channel: ``bernoulli``, ``gilbert_elliott`` or ``markov``."""
    if not isinstance(obj, dict):
        raise InvalidInput(where, "expected a JSON object")
    model = obj.get("model")
    if model == "bernoulli":
        check_keys(obj, where, {"model", "arrival_probability"}, {"arrival_probability"})
        lam = _parse_probability(obj["arrival_probability"], f"{where}/arrival_probability", limits)
        return MarkovChannel("bernoulli", 0, (lam,), {"arrival_probability": lam})
    if model == "gilbert_elliott":
        check_keys(obj, where, {"model", "failure_rate", "recovery_rate"}, {"failure_rate", "recovery_rate"})
        p = _parse_probability(obj["failure_rate"], f"{where}/failure_rate", limits)
        q = _parse_probability(obj["recovery_rate"], f"{where}/recovery_rate", limits)
        return MarkovChannel("gilbert_elliott", 1, (q, 1 - p), {"failure_rate": p, "recovery_rate": q})
    if model == "markov":
        check_keys(obj, where, {"model", "order", "arrival_probability"}, {"order", "arrival_probability"})
        nu = obj["order"]
        if isinstance(nu, bool) or not isinstance(nu, int) or nu < 0:
            raise InvalidInput(f"{where}/order", "order must be a non-negative integer")
        if nu > limits.max_markov_order:
            raise LimitExceeded(f"{where}/order", f"Markov order {nu} exceeds the limit {limits.max_markov_order}")
        table_obj = obj["arrival_probability"]
        if not isinstance(table_obj, dict):
            raise InvalidInput(
                f"{where}/arrival_probability", 'expected an object mapping histories such as "01" to probabilities'
            )
        table: list[Fraction | None] = [None] * (1 << nu)
        for key, val in table_obj.items():
            kw = pointer(f"{where}/arrival_probability", key)
            if len(key) != nu or any(ch not in "01" for ch in key):
                raise InvalidInput(kw, f"a history key must be {nu} characters of 0/1 (oldest first)")
            table[int(key, 2) if nu else 0] = _parse_probability(val, kw, limits)
        missing = [format(h, f"0{nu}b") if nu else "" for h, v in enumerate(table) if v is None]
        if missing:
            shown = ", ".join(repr(m) for m in missing[:4]) + (" ..." if len(missing) > 4 else "")
            raise InvalidInput(
                f"{where}/arrival_probability", f"missing histories: {shown} (all {1 << nu} are required)"
            )
        tbl = tuple(x for x in table if x is not None)
        params = {format(h, f"0{nu}b") if nu else "": v for h, v in enumerate(tbl)}
        return MarkovChannel("markov", nu, tbl, params)
    allowed = "'bernoulli', 'gilbert_elliott', 'markov'"
    if model == "per_sensor":
        raise InvalidInput(
            f"{where}/model", "'per_sensor' is only allowed at the top level of channel, with system.sensors"
        )
    raise InvalidInput(f"{where}/model", f"unknown channel model {value_text(model)}; expected one of {allowed}")


def parse_channel(obj: Any, system: System, limits: Limits = DEFAULT_LIMITS, where: str = "/channel") -> Channel:
    """Validate ``channel``; ``per_sensor`` needs ``system.sensors`` and one channel per sensor."""
    if isinstance(obj, dict) and obj.get("model") == "per_sensor":
        check_keys(obj, where, {"model", "channels"}, {"channels"})
        if system.sensors is None:
            raise InvalidInput(f"{where}/model", "a per_sensor channel needs system.sensors")
        chans = obj["channels"]
        if not isinstance(chans, dict):
            raise InvalidInput(f"{where}/channels", "expected an object mapping sensor names to channels")
        names = [s.name for s in system.sensors]
        for key in chans:
            if key not in names:
                raise InvalidInput(
                    pointer(f"{where}/channels", key), f"unknown sensor {key[:64]!r}; sensors are {names}"
                )
        out = []
        for name in names:
            if name not in chans:
                raise InvalidInput(pointer(f"{where}/channels", name), f"sensor {name!r} has no channel")
            out.append((name, parse_markov_channel(chans[name], limits, pointer(f"{where}/channels", name))))
        return PerSensorChannel(tuple(out))
    if system.sensors is not None and len(system.sensors) > 1:
        raise InvalidInput(
            f"{where}/model", "with several sensors the channel must be {'model': 'per_sensor', 'channels': {...}}"
        )
    return parse_markov_channel(obj, limits, where)


_TIME_BUDGET = option_field("", "time_budget_s")
#: Smallest ``options.time_budget_s`` (seconds): less cannot even hand a request to a worker.
MIN_TIME_BUDGET_S = Fraction(_TIME_BUDGET.minimum or 0)


def parse_time_budget(value: Any, limits: Limits = DEFAULT_LIMITS) -> float:
    """``options.time_budget_s`` in seconds, in the range of :data:`kfio.model.OPTION_FIELDS`."""
    t = parse_number(value, _TIME_BUDGET.pointer, limits.max_digits)
    if not _TIME_BUDGET.admits(t):
        raise InvalidInput(
            _TIME_BUDGET.pointer,
            f"time_budget_s must be in [{float(MIN_TIME_BUDGET_S):g}, {_TIME_BUDGET.maximum}] seconds",
        )
    return float(t)


def parse_request(obj: Any, limits: Limits = DEFAULT_LIMITS, *, system: System | None = None) -> Request:
    """Validate a whole request (the JSON tree of :func:`load_json`).

    ``system``: :func:`parse_system` of ``obj["system"]`` with ``limits``, when
    the caller already has it (a sweep whose points share one plant); the
    rest of the request is validated as always.

    Examples
    --------
    >>> request = parse_request({"system": {"A": [[1.1]], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": "1/2"}})
    >>> request.system.A, request.channel.model
    (((Fraction(11, 10),),), 'bernoulli')
    """
    obj = check_keys(obj, "", _TOP_KEYS, {"system", "channel"})
    if system is None:
        system = parse_system(obj["system"], limits)
    channel = parse_channel(obj["channel"], system, limits)
    options: dict[str, Mapping[str, Any]] = {}
    time_budget = None
    if "options" in obj:
        opts = check_keys(obj["options"], "/options", set(OPTION_GROUPS) | {f.name for f in option_fields("")}, set())
        for key, val in opts.items():
            if key == "time_budget_s":
                time_budget = parse_time_budget(val, limits)
            elif not isinstance(val, dict):
                raise InvalidInput(f"/options/{key}", "expected a JSON object")
            else:
                check_keys(val, f"/options/{key}", OPTION_KEYS[key], set(), "option")
                options[key] = val
    return Request(system=system, channel=channel, options=options, time_budget_s=time_budget)


def option_group(request: Request, group: str, allowed: Iterable[str]) -> Mapping[str, Any]:
    """``request.options[group]`` (``{}`` if absent), with every key checked against ``allowed``.

    Each command validates the values of its own group; the unknown-key rule is
    the same for all, and its message names ``/options/<group>/<key>``.
    """
    raw = request.options.get(group, {})
    where = f"/options/{group}"
    if not isinstance(raw, Mapping):
        raise InvalidInput(where, "expected a JSON object")
    names = sorted(allowed)
    for key in raw:
        if key not in names:
            raise InvalidInput(pointer(where, key), f"unknown option {key[:64]!r}; allowed: {', '.join(names)}")
    return raw


def load_request(text: str | bytes, limits: Limits = DEFAULT_LIMITS) -> Request:
    """Parse and validate request JSON text in one step (:func:`load_json`, then :func:`parse_request`).

    Examples
    --------
    >>> load_request('{"system": {"A": [[1.1]], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": 0.5}}').system.A
    ((Fraction(11, 10),),)
    """
    return parse_request(load_json(text), limits)


def require_assumption_1(channel: Channel) -> None:
    """Raise :class:`AssumptionViolation` if a channel probability is 0 or 1.

    Rohr, Marelli and Fu (2014), Assumption 1: ``0 < P(g_t = 1 | history) < 1`` for every history.
    Theorem 1 says nothing outside it, so no verdict is returned.
    """
    from ..errors import AssumptionViolation

    chans = channel.channels if isinstance(channel, PerSensorChannel) else (("", channel),)
    for name, ch in chans:
        base = json_pointer(("channel", "channels", name)) if name else "/channel"
        for h, x in enumerate(ch.table):
            if x in (0, 1):
                if ch.model == "bernoulli":
                    fld = f"{base}/arrival_probability"
                elif ch.model == "gilbert_elliott":
                    fld = f"{base}/recovery_rate" if h == 0 else f"{base}/failure_rate"
                else:
                    fld = f"{base}/arrival_probability/{format(h, f'0{ch.order}b') if ch.order else ''}"
                raise AssumptionViolation(
                    fld,
                    "Assumption 1 of Rohr, Marelli and Fu 2014 requires every conditional arrival probability to lie strictly "
                    f"between 0 and 1 (got {int(x)}); Theorem 1 gives no verdict for this channel",
                )
