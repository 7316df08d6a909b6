"""The plant and channel model, and the one route from user input to it.

Exact rationals from decimal text (:func:`parse_number`), the single validator
(:func:`parse_request`, :func:`load_request`) and the typed request objects.
The plant has one public name, :class:`kfio.System` (which validates what it
is given); the validator's own frozen record of a plant, the type of
``Request.system``, is its base class and is not exported here.
"""

from ._exact import fraction_text, load_json, parse_number
from ._limits import DEFAULT_LIMITS, Limits
from ._pointer import json_pointer, pointer_tokens
from ._request import load_request, parse_request
from ._types import MarkovChannel, PerSensorChannel, Request, Sensor

__all__ = [
    "DEFAULT_LIMITS",
    "Limits",
    "MarkovChannel",
    "PerSensorChannel",
    "Request",
    "Sensor",
    "fraction_text",
    "json_pointer",
    "load_json",
    "load_request",
    "parse_number",
    "parse_request",
    "pointer_tokens",
]
