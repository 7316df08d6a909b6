"""The options a request may carry, declared once: name, type, range, default, description.

The option parsers of every command read their ranges, enums and defaults from
:data:`OPTION_FIELDS`, :data:`OPTION_KEYS` is derived from it, and the service
renders the JSON Schemas and the OpenAPI document from it, so a range cannot
say one thing in the validator and another in the published schema.  The
validator keeps the rules a table cannot say (``grid`` needs two sensors, the
horizon's upper end shrinks with ``n``, ``steps * trajectories`` is capped):
each field's ``description`` names them.

Numbers are exact (``Fraction``); ``exclusive_minimum``/``exclusive_maximum``
make an end open.  ``maximum`` of ``bounds.horizon`` is its largest value over
all plants (one state), not the limit of every request.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Literal, Union

from ._exact import number_text_limit
from ._limits import DEFAULT_LIMITS

#: How a field's value is written: ``integer`` (a JSON integer), ``number`` (an exact number,
#: JSON number or its text), ``enum`` (one of ``enum``), ``pointer`` (a JSON pointer string),
#: ``matrix``, ``probability_or_map`` (a probability or ``{sensor: probability}``), ``number_list``
#: (1 to ``max_items`` exact numbers), ``object`` (the fields ``properties``), ``fixed`` (``default`` only).
Kind = Literal["integer", "number", "enum", "pointer", "matrix", "probability_or_map", "number_list", "object", "fixed"]

Bound = Union[int, Fraction, None]


@dataclass(frozen=True)
class OptionField:
    """One option of a request: where it lives, what it accepts, its default and what it means.

    ``group`` is the command's option group (``"analyze"``, ``"bounds"``,
    ``"simulate"``, ``"loop"``; ``"sweep"`` for a sweep file's options), ``""`` for a top-level option
    (``options.time_budget_s``), or ``"<group>.<key>"`` for a key of an
    object-valued option.  ``default`` is ``None`` when the option has none
    (or it depends on the request; ``description`` says so).
    """

    group: str
    name: str
    kind: Kind
    description: str
    minimum: Bound = None
    maximum: Bound = None
    exclusive_minimum: bool = False
    exclusive_maximum: bool = False
    default: Any = None
    enum: tuple[str, ...] = ()
    max_items: int | None = None
    #: Most characters of a ``number`` written as JSON text, when shorter than any exact number's.
    max_text: int | None = None
    properties: tuple[OptionField, ...] = ()
    required: tuple[str, ...] = ()

    @property
    def pointer(self) -> str:
        """The JSON pointer of this option in a request, such as ``/options/bounds/grid``.

        The ``sweep`` group is the sweep file's own ``options`` object: ``/options/chunk_size``.
        """
        if self.group == "sweep":
            return "/options/" + self.name
        return "/options/" + "/".join([*self.group.split("."), self.name] if self.group else [self.name])

    def admits(self, value: Fraction | int) -> bool:
        """Whether a number lies in this field's range (the ends as ``exclusive_*`` say)."""
        if self.minimum is not None and (value <= self.minimum if self.exclusive_minimum else value < self.minimum):
            return False
        if self.maximum is not None and (value >= self.maximum if self.exclusive_maximum else value > self.maximum):
            return False
        return True

    def prop(self, name: str) -> OptionField:
        """The key ``name`` of an object-valued option."""
        for p in self.properties:
            if p.name == name:
                return p
        raise KeyError(name)


#: Most characters of an exact number written as text, with the default limits.
MAX_NUMBER_TEXT = number_text_limit(DEFAULT_LIMITS.max_digits)

#: Most characters of a sensor name.
MAX_SENSOR_NAME = 64

#: Most entries of a check file (``kfio check``).
MAX_CHECK_ENTRIES = 1000

#: Longest budget of one whole run, in seconds (a day): a check file's ``time_budget_s`` and ``point_budget_s``,
#: a sweep file's ``time_budget_s``, a command's ``--time-budget`` and a service job.
MAX_RUN_BUDGET_S = 86400

OPTION_FIELDS: tuple[OptionField, ...] = (
    OptionField(
        "",
        "time_budget_s",
        "number",
        "Seconds this request may take (an exact number; less than the minimum cannot even reach a worker, and is "
        "422); the deployment's budget caps it.",
        minimum=Fraction(1, 100),
        maximum=3600,
    ),
    OptionField(
        "analyze",
        "ge_grid",
        "integer",
        "Gilbert-Elliott channel only: cells per axis of the exact (failure rate, recovery rate) stability map "
        "added to the report (gilbert_elliott_region.map).",
        minimum=2,
        maximum=101,
    ),
    OptionField(
        "analyze",
        "critical_parameter",
        "pointer",
        "A JSON pointer into channel naming one conditional arrival probability (/channel/recovery_rate, "
        "/channel/failure_rate, /channel/arrival_probability/01, /channel/channels/<sensor>/...); the report's "
        "critical_parameter gives its exact critical value(s) with the other parameters fixed.",
    ),
    OptionField(
        "bounds",
        "tolerance",
        "number",
        "Bisection tolerance of the certified upper bound lambda_upper.",
        minimum=Fraction("1e-9"),
        maximum=Fraction("1e-1"),
        default=Fraction("1e-6"),
    ),
    OptionField(
        "bounds",
        "horizon",
        "integer",
        "Largest N of P_hat_N (Rohr, Marelli and Fu 2010); one packet only.  The largest N shrinks with the "
        "number of states n (20 up to n = 4, 15 at n = 10, 7 at n = 40); the default is 8 or that limit.",
        minimum=1,
        maximum=20,
        default=8,
    ),
    OptionField(
        "bounds",
        "grid",
        "integer",
        "Two sensors only: cells per axis of the region map of the two arrival probabilities.",
        minimum=2,
        maximum=41,
    ),
    OptionField(
        "bounds",
        "arrival_probability",
        "probability_or_map",
        "The operating point: a probability with one packet, {sensor name: probability} with several "
        "(default: the channel's).",
    ),
    OptionField(
        "bounds",
        "trace_target",
        "number",
        "A target T; the report's trace_target gives the smallest arrival probability at which the certified "
        "upper bound trace(V_bar) is at most T (one Bernoulli packet; bisection, V_bar decreases with lambda: "
        "Sinopoli et al. 2004).",
        minimum=0,
        exclusive_minimum=True,
    ),
    OptionField(
        "bounds",
        "sdp_cross_check",
        "enum",
        "Whether the V_bar SDP cross-check is solved: auto solves it up to 12 states and skips it above, where "
        "V_bar comes from the MARE iteration alone.",
        enum=("auto", "always", "never"),
        default="auto",
    ),
    OptionField(
        "simulate",
        "steps",
        "integer",
        "Horizon T of the Monte Carlo run.",
        minimum=1,
        maximum=10_000,
        default=200,
    ),
    OptionField(
        "simulate",
        "trajectories",
        "integer",
        "Independent trajectories M, with steps * trajectories <= 10^6 and trajectories * n^2 <= 2^25 (default "
        "10 000, or fewer to fit 10^6).",
        minimum=2,
        default=10_000,
    ),
    OptionField(
        "simulate",
        "seed",
        "integer",
        "Seed of numpy's PCG64 generator: the same seed gives the same report, bit for bit.",
        minimum=0,
        maximum=(1 << 64) - 1,
        default=0,
    ),
    OptionField(
        "simulate",
        "P0",
        "matrix",
        "Initial error covariance P_0, symmetric positive semidefinite n x n, exact (default Q).",
    ),
    OptionField(
        "simulate",
        "exact_steps",
        "integer",
        "Horizon of the exact enumeration of E[P_t], with 2^(m * exact_steps) <= 2^20 for m packets.",
        minimum=0,
    ),
    OptionField(
        "simulate",
        "initial_channel",
        "enum",
        "Each packet's channel history before t = 0: drawn from the stationary distribution, or nu arrivals, "
        "or nu losses.",
        enum=("stationary", "all_arrived", "all_lost"),
        default="stationary",
    ),
    OptionField(
        "simulate",
        "percentiles",
        "fixed",
        "The percentiles of trace(P_t) reported; fixed, accepted only with this value.",
        default=(50, 90, 99),
    ),
    OptionField(
        "simulate",
        "outage_thresholds",
        "number_list",
        "Positive numbers M; the report's stationary.outage gives P(trace P > M) with a 95% interval for each.",
        max_items=20,
        minimum=0,
        exclusive_minimum=True,
    ),
    OptionField(
        "simulate",
        "outage_target",
        "object",
        "The report's outage_target gives the smallest arrival probability at which the estimated stationary "
        "outage P(trace P > M) is at most epsilon, with the bracket where its 95% interval straddles epsilon (one "
        "Bernoulli packet; bisection over lambda with common random numbers; estimated, not certified).",
        properties=(
            OptionField(
                "simulate.outage_target",
                "threshold",
                "number",
                "The threshold M of trace P.",
                minimum=0,
                exclusive_minimum=True,
            ),
            OptionField(
                "simulate.outage_target",
                "epsilon",
                "number",
                "The outage probability to reach.",
                minimum=0,
                maximum=1,
                exclusive_minimum=True,
                exclusive_maximum=True,
            ),
            OptionField(
                "simulate.outage_target",
                "tolerance",
                "number",
                "Bisection tolerance on the arrival probability.",
                minimum=0,
                maximum=Fraction(1, 4),
                exclusive_minimum=True,
                default=Fraction(1, 256),
            ),
        ),
        required=("threshold", "epsilon"),
    ),
    OptionField(
        "loop",
        "protocol",
        "enum",
        "tcp: the controller knows whether each actuator packet arrived; udp: it does not.",
        enum=("tcp", "udp"),
        default="tcp",
    ),
    OptionField(
        "loop",
        "on_loss",
        "enum",
        "What the actuator applies when its packet is lost: zero, or the last input it received (hold).",
        enum=("zero", "hold"),
        default="zero",
    ),
    OptionField(
        "loop",
        "region",
        "integer",
        "Add the exact boundary of the stable region in the (sensor, actuator) arrival-probability plane at this "
        "many sensor probabilities (Bernoulli links on both sides).",
        minimum=2,
        maximum=41,
    ),
    OptionField(
        "sweep",
        "point_budget_s",
        "number",
        "Seconds each point may take (an exact number).",
        minimum=Fraction(1, 100),
        maximum=3600,
        default=60,
        max_text=40,
    ),
    OptionField(
        "sweep",
        "time_budget_s",
        "number",
        "Seconds the whole sweep may take (an exact number); the points not reached are marked budget-exceeded.",
        minimum=Fraction(1, 100),
        maximum=MAX_RUN_BUDGET_S,
        max_text=40,
    ),
    OptionField("sweep", "chunk_size", "integer", "Points per task sent to a worker.", minimum=1, maximum=100_000),
)

#: The option groups of a request (one per command that reads a request) in the order the
#: validator lists them; the loop request has its own group, ``loop``.
REQUEST_GROUPS = ("analyze", "bounds", "simulate")
#: The groups of a request and of the loop request; the table's ``sweep`` group is the sweep file's own ``options``.
OPTION_GROUP_NAMES = (*REQUEST_GROUPS, "loop")


def option_fields(group: str) -> tuple[OptionField, ...]:
    """The fields of one option group (``""`` for the top-level options), in table order."""
    return tuple(f for f in OPTION_FIELDS if f.group == group)


def option_field(group: str, name: str) -> OptionField:
    """The field ``name`` of ``group`` (``""`` for a top-level option).

    >>> option_field("bounds", "grid").maximum
    41
    """
    for f in OPTION_FIELDS:
        if f.group == group and f.name == name:
            return f
    raise KeyError(f"{group}.{name}" if group else name)


#: Option groups a request may carry, one per command, and the keys of each.  Every command
#: refuses an unknown key in any group (the contract says so), and validates the values of its own.
OPTION_KEYS: dict[str, frozenset[str]] = {g: frozenset(f.name for f in option_fields(g)) for g in REQUEST_GROUPS}
