"""kfio's math library: stability of Kalman filters with lossy measurement channels.

Knows nothing of HTTP or the command line (see :mod:`service`).  Exact in,
exact through, converted at the edge.
"""

from .budget import Budget
from .errors import (
    AnalyzerError,
    AssumptionViolation,
    BudgetExceeded,
    InvalidInput,
    LimitExceeded,
    NumericalFailure,
)
from .exact import load_json, parse_number
from .limits import DEFAULT_LIMITS, Limits
from .model import MarkovChannel, PerSensorChannel, Request, Sensor, System
from .request import load_request, parse_request
from .verdict import StabilityReport, analyze

__all__ = [
    "AnalyzerError",
    "AssumptionViolation",
    "Budget",
    "BudgetExceeded",
    "DEFAULT_LIMITS",
    "InvalidInput",
    "LimitExceeded",
    "Limits",
    "MarkovChannel",
    "NumericalFailure",
    "PerSensorChannel",
    "Request",
    "Sensor",
    "StabilityReport",
    "System",
    "analyze",
    "load_json",
    "load_request",
    "parse_number",
    "parse_request",
]
