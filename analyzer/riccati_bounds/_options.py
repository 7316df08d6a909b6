"""Validation of what ``kfio bounds`` needs beyond a valid request.

The request parser (:mod:`kfio.model._request`) has already checked shapes,
``Q >= 0``, ``R > 0`` and that sensors partition the rows of ``C``.  Here:
``Q`` and ``R`` must be present, every packet's channel must be i.i.d.
(the bounds of Sinopoli et al. (2004) and Liu and Goldsmith (2004) are about Bernoulli losses), the LMI must
fit the size limit, and ``request.options["bounds"]`` is checked key by key.
Every error names its field as a JSON pointer.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Mapping

from ..errors import InvalidInput, LimitExceeded
from ..model import (
    OPTION_KEYS,
    MarkovChannel,
    Packet,
    Request,
    json_pointer,
    option_field,
    option_group,
    packets_of,
    parse_integer,
    parse_number,
)
from ._phat import max_horizon
from ._vbar_sdp import COMPILED_MAX_N

_TOLERANCE = option_field("bounds", "tolerance")
DEFAULT_TOLERANCE = float(_TOLERANCE.default)
MIN_TOLERANCE, MAX_TOLERANCE = float(_TOLERANCE.minimum or 0), float(_TOLERANCE.maximum or 0)
_HORIZON = option_field("bounds", "horizon")
DEFAULT_HORIZON = int(_HORIZON.default)
MIN_HORIZON = int(_HORIZON.minimum or 0)
_GRID = option_field("bounds", "grid")
MIN_GRID, MAX_GRID = int(_GRID.minimum or 0), int(_GRID.maximum or 0)
#: The stability LMI has ``n (2^m + 1)`` rows for ``n`` states and ``m`` packets.
MAX_LMI_ROWS = 200
_SDP = option_field("bounds", "sdp_cross_check")
#: Values of ``options.bounds.sdp_cross_check``; ``"auto"`` solves the ``V_bar`` SDP up to
#: :data:`SDP_AUTO_MAX_N` states.
SDP_CROSS_CHECK = _SDP.enum
#: Largest ``n`` at which ``"auto"`` solves the ``V_bar`` SDP (the compiled problems' limit,
#: :data:`kfio.riccati_bounds._vbar_sdp.COMPILED_MAX_N`; 20 s of Clarabel at ``n = 40``).
SDP_AUTO_MAX_N = COMPILED_MAX_N

#: Largest entry magnitude (``10^MAX_FLOAT_EXPONENT``) of A, C, Q, R for the floating-point bounds.
MAX_FLOAT_EXPONENT = 30
MAX_FLOAT_ENTRY = Fraction(10) ** MAX_FLOAT_EXPONENT

_KEYS = OPTION_KEYS["bounds"]
_WHERE = "/options/bounds"


@dataclass(frozen=True)
class BoundsOptions:
    """Validated options of the bounds command.

    Attributes
    ----------
    packets:
        The packets, in request order.
    arrival:
        Exact arrival probability of each packet (channel value or override).
    tolerance:
        Bisection tolerance for ``lambda_upper``.
    horizon:
        Largest ``N`` of Rohr, Marelli and Fu (2010)'s ``P_hat_N`` (one packet only), else ``None``.
    grid:
        Side ``K`` of the region map (two packets only), or ``None``.
    sdp_cross_check:
        ``"auto"``, ``"always"`` or ``"never"``: whether the ``V_bar`` SDP cross-check is solved.
    """

    packets: tuple[Packet, ...]
    arrival: tuple[Fraction, ...]
    tolerance: float
    horizon: int | None
    grid: int | None
    sdp_cross_check: str = "auto"

    def solve_sdp(self, n: int) -> bool:
        """Whether the ``V_bar`` SDP is solved for ``n`` states."""
        return self.sdp_cross_check == "always" or (self.sdp_cross_check == "auto" and n <= SDP_AUTO_MAX_N)

    def sdp_skipped_because(self, n: int) -> str | None:
        """Why the ``V_bar`` SDP is not solved for ``n`` states (the report's reason), or ``None``."""
        if self.solve_sdp(n):
            return None
        if self.sdp_cross_check == "never":
            return "not solved: options.bounds.sdp_cross_check is 'never'"
        return (
            f"not solved: the cross-check is skipped above {SDP_AUTO_MAX_N} states (n = {n}; it costs seconds to "
            "minutes there); V_bar is the MARE iteration's; set options.bounds.sdp_cross_check to 'always' to solve it"
        )


def _source(key: str, flags: Mapping[str, Any]) -> str:
    return f" (given as --{key.replace('_', '-')})" if key in flags else ""


#: Integer options are range-checked against this before conversion (the precise
#: limits follow); an exponent bomb such as ``1e999999999`` never becomes an ``int``.
_COARSE_INTEGER_LIMIT = 10**6


def _integer(value: Any, key: str, flags: Mapping[str, Any]) -> int:
    at = f"{_WHERE}/{key}"
    try:
        return parse_integer(value, at, -_COARSE_INTEGER_LIMIT, _COARSE_INTEGER_LIMIT, key)
    except InvalidInput as exc:
        raise type(exc)(at, exc.rule + _source(key, flags)) from None


def _check_float_range(request: Request) -> None:
    """The bounds are floating-point computations: entries beyond :data:`MAX_FLOAT_ENTRY` are refused.

    ``rho(A)^2``, ``A P A'`` and the LMI blocks square the entries; at
    ``|a| = 10^160`` (a valid exact input) they overflow float64.  The exact
    verdict (``kfio analyze``) has no such limit.
    """
    for name, M in (("A", request.system.A), ("C", request.system.C), ("Q", request.system.Q), ("R", request.system.R)):
        for i, row in enumerate(M or ()):
            for j, x in enumerate(row):
                if abs(x) > MAX_FLOAT_ENTRY:
                    raise LimitExceeded(
                        f"/system/{name}/{i}/{j}",
                        f"the bounds are computed in floating point; entries of {name} must have magnitude at most "
                        f"1e{MAX_FLOAT_EXPONENT} (kfio analyze decides the exact verdict without this limit)",
                    )


def _iid(channel: MarkovChannel, where: str) -> Fraction:
    lam = channel.bernoulli_lambda
    if lam is None:
        raise InvalidInput(
            f"{where}/model",
            f"the bounds of Sinopoli et al. 2004 and Liu and Goldsmith 2004 assume i.i.d. (Bernoulli) packet losses; this {channel.model} "
            "channel has memory (use 'kfio analyze' for its exact verdict)",
        )
    return lam


def _packets(request: Request) -> tuple[tuple[Packet, ...], tuple[Fraction, ...]]:
    packets = packets_of(request)
    return packets, tuple(_iid(p.channel, p.where) for p in packets)


def _arrival_overrides(raw: Any, packets: tuple[Packet, ...], lams: tuple[Fraction, ...]) -> tuple[Fraction, ...]:
    where = f"{_WHERE}/arrival_probability"

    def prob(x: Any, at: str) -> Fraction:
        if isinstance(x, bool):
            raise InvalidInput(at, "an arrival probability must be a number in [0, 1]")
        v = parse_number(x, at)
        if not 0 <= v <= 1:
            raise InvalidInput(at, f"an arrival probability must lie in [0, 1]; got {float(v):g}")
        return v

    if len(packets) == 1:
        if isinstance(raw, dict):
            raise InvalidInput(where, "with one packet, arrival_probability is a number in [0, 1]")
        return (prob(raw, where),)
    if not isinstance(raw, dict):
        raise InvalidInput(where, "with several sensors, arrival_probability maps sensor names to probabilities")
    names = [p.name for p in packets]
    out = list(lams)
    for key, val in raw.items():
        if key not in names:
            raise InvalidInput(where + json_pointer((key,)), f"unknown sensor {key[:64]!r}; sensors are {names}")
        out[names.index(key)] = prob(val, where + json_pointer((key,)))
    return tuple(out)


def parse_bounds_options(request: Request, flags: Mapping[str, Any] | None = None) -> BoundsOptions:
    """Validate a request for the bounds command; ``flags`` (CLI) override ``options.bounds``.

    Raises
    ------
    InvalidInput
        Missing ``Q``/``R``, a channel with memory, or a bad option; the
        field is ``/system/Q``, ``/channel/...`` or ``/options/bounds/<key>``.
    LimitExceeded
        The LMI would exceed :data:`MAX_LMI_ROWS` rows, a horizon or grid
        beyond its limit.
    """
    flags = dict(flags or {})
    system = request.system
    if system.Q is None:
        raise InvalidInput("/system/Q", "the bounds need the process noise covariance Q")
    if system.R is None:
        raise InvalidInput("/system/R", "the bounds need the measurement noise covariance R")
    _check_float_range(request)
    packets, lams = _packets(request)
    n, m = system.n, len(packets)
    if n * ((1 << m) + 1) > MAX_LMI_ROWS:
        raise LimitExceeded(
            "/system/sensors",
            f"the stability LMI for {n} states and {m} sensors has n(2^m + 1) = {n * ((1 << m) + 1)} rows; "
            f"the limit is {MAX_LMI_ROWS}",
        )
    raw = option_group(request, "bounds", _KEYS)
    merged = {**raw, **{k: v for k, v in flags.items() if v is not None}}

    tolerance = DEFAULT_TOLERANCE
    if "tolerance" in merged:
        at = f"{_WHERE}/tolerance"
        if isinstance(merged["tolerance"], bool):
            raise InvalidInput(at, "tolerance must be a number")
        t = float(parse_number(merged["tolerance"], at))
        if not MIN_TOLERANCE <= t <= MAX_TOLERANCE:
            raise InvalidInput(
                at,
                f"tolerance must lie in [{MIN_TOLERANCE:g}, {MAX_TOLERANCE:g}]; got {t:g}{_source('tolerance', flags)}",
            )
        tolerance = t

    limit = max_horizon(n)
    horizon: int | None = min(DEFAULT_HORIZON, limit) if m == 1 else None
    if "horizon" in merged:
        at = f"{_WHERE}/horizon"
        h = _integer(merged["horizon"], "horizon", flags)
        if m != 1:
            raise InvalidInput(
                at, f"P_hat_N (Rohr, Marelli and Fu 2010) is defined for one packet; this request has {m} sensors"
            )
        if h < MIN_HORIZON:
            raise InvalidInput(at, f"horizon must be at least {MIN_HORIZON}{_source('horizon', flags)}")
        if h > limit:
            raise LimitExceeded(
                at,
                f"horizon {h} exceeds the limit {limit} for {n} states (g_N costs 2^N n^4/4){_source('horizon', flags)}",
            )
        horizon = h

    grid = None
    if "grid" in merged:
        at = f"{_WHERE}/grid"
        k = _integer(merged["grid"], "grid", flags)
        if m != 2:
            raise InvalidInput(at, f"the region map needs exactly two sensors; this request has {m}")
        if not MIN_GRID <= k <= MAX_GRID:
            raise LimitExceeded(at, f"grid must lie in [{MIN_GRID}, {MAX_GRID}]; got {k}{_source('grid', flags)}")
        grid = k

    sdp = str(_SDP.default)
    if "sdp_cross_check" in merged:
        sdp = merged["sdp_cross_check"]
        if not isinstance(sdp, str) or sdp not in SDP_CROSS_CHECK:
            shown = repr(sdp[:64]) if isinstance(sdp, str) else "a value that is not a string"
            raise InvalidInput(
                f"{_WHERE}/sdp_cross_check",
                f"sdp_cross_check must be one of {', '.join(repr(v) for v in SDP_CROSS_CHECK)}; got {shown}"
                f"{_source('sdp_cross_check', flags)}",
            )

    if "arrival_probability" in merged:
        lams = _arrival_overrides(merged["arrival_probability"], packets, lams)
    return BoundsOptions(packets, lams, tolerance, horizon, grid, sdp)
