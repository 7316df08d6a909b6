"""Base requests and the real option validators of each command, for the tests that probe option ranges.

tests/test_docs_options.py (the docs' tables against the validator) and
tests/model/test_fields.py (the option table against the validator and the
schemas) probe the same validators on the same small plants.
"""

from __future__ import annotations

from typing import Any, Callable

from kfio.design._design_options import analyze_options
from kfio.model._types import Request
from kfio.riccati_bounds._options import parse_bounds_options
from kfio.riccati_bounds._targets import parse_trace_target
from kfio.simulation._outage_target import parse_outage_target
from kfio.simulation._setup import parse_options as parse_simulate_options
from kfio.simulation._stationary import parse_thresholds

ONE = {"A": [[2]], "C": [[1]], "Q": [[1]], "R": [[1]]}
TWO = {"A": [[2, 0], [0, 1.5]], "C": [[1, 0], [0, 1]], "Q": [[1, 0], [0, 1]], "R": [[1, 0], [0, 1]]}
SENSORS = [{"name": "a", "rows": [0]}, {"name": "b", "rows": [1]}]
#: A valid request per kind of plant and channel an option may need.
BASES: dict[str, dict[str, Any]] = {
    "one": {"system": ONE, "channel": {"model": "bernoulli", "arrival_probability": 0.9}},
    "ge": {"system": ONE, "channel": {"model": "gilbert_elliott", "failure_rate": 0.1, "recovery_rate": 0.6}},
    "two": {
        "system": dict(TWO, sensors=SENSORS),
        "channel": {
            "model": "per_sensor",
            "channels": {n: {"model": "bernoulli", "arrival_probability": 0.9} for n in "ab"},
        },
    },
}
#: Which base request an option needs to be valid at all.
NEEDS = {"analyze.ge_grid": "ge", "bounds.grid": "two"}


def _validate_analyze(r: Request) -> None:
    analyze_options(r)


def _validate_bounds(r: Request) -> None:
    parse_bounds_options(r)
    parse_trace_target(r)


def _validate_simulate(r: Request) -> None:
    parse_simulate_options(r)
    parse_thresholds(r)
    parse_outage_target(r)


#: The validators of each command's option group, as the command runs them.
VALIDATORS: dict[str, Callable[[Request], None]] = {
    "analyze": _validate_analyze,
    "bounds": _validate_bounds,
    "simulate": _validate_simulate,
}
