"""The plant and channel model, and the one route from user input to it.

Exact rationals from decimal text (:func:`parse_number`), the single validator
(:func:`parse_request`, :func:`load_request`) and the typed request objects.
The plant has one public name, :class:`kfio.System` (which validates what it
is given); the validator's own frozen record of a plant, the type of
``Request.system``, is its base class and is not exported here.
"""

from ._channels import bernoulli, channel_tree, gilbert_elliott, markov, per_sensor
from ._coerce import Route, budget_seconds, json_ready, python_tree, renamed
from ._exact import (
    DECIMAL_PATTERN,
    MAX_EXACT_DIGITS,
    WITHHELD_TEXT,
    capped_fraction_text,
    decimal_enclosure,
    escaped,
    fraction_digits,
    fraction_text,
    load_json,
    parse_integer,
    parse_number,
    value_text,
    values_withheld,
)
from ._limits import DEFAULT_LIMITS, Limits
from ._pointer import json_pointer, pointer_tokens
from ._request import (
    MIN_TIME_BUDGET_S,
    OPTION_KEYS,
    check_keys,
    check_symmetric,
    is_positive_definite,
    is_psd,
    load_request,
    option_group,
    parse_channel,
    parse_markov_channel,
    parse_matrix,
    parse_request,
    parse_system,
    require_assumption_1,
)
from ._types import (
    Channel,
    MarkovChannel,
    Matrix,
    Packet,
    PerSensorChannel,
    Request,
    Sensor,
    packets_of,
    to_domain,
    to_float,
)
from ._types import System as SystemRecord

__all__ = [
    "Channel",
    "DECIMAL_PATTERN",
    "DEFAULT_LIMITS",
    "Limits",
    "MIN_TIME_BUDGET_S",
    "MarkovChannel",
    "Matrix",
    "OPTION_KEYS",
    "Packet",
    "PerSensorChannel",
    "Request",
    "Route",
    "Sensor",
    "SystemRecord",
    "WITHHELD_TEXT",
    "bernoulli",
    "channel_tree",
    "check_keys",
    "check_symmetric",
    "escaped",
    "MAX_EXACT_DIGITS",
    "capped_fraction_text",
    "decimal_enclosure",
    "fraction_digits",
    "fraction_text",
    "gilbert_elliott",
    "is_positive_definite",
    "is_psd",
    "json_pointer",
    "json_ready",
    "load_json",
    "load_request",
    "markov",
    "option_group",
    "packets_of",
    "parse_channel",
    "parse_integer",
    "parse_markov_channel",
    "parse_matrix",
    "parse_number",
    "parse_request",
    "parse_system",
    "per_sensor",
    "pointer_tokens",
    "python_tree",
    "renamed",
    "budget_seconds",
    "require_assumption_1",
    "to_domain",
    "to_float",
    "value_text",
    "values_withheld",
]
