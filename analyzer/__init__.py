"""kfio's math library: stability of Kalman filters with lossy measurement channels.

Knows nothing of HTTP or the command line (see :mod:`kfio.service`).  Exact in,
exact through, converted at the edge.
"""

from ._budget import Budget
from .errors import (
    AnalyzerError,
    AssumptionViolation,
    BudgetExceeded,
    InvalidInput,
    LimitExceeded,
    NumericalFailure,
)
from .model._exact import load_json, parse_number
from .model._limits import DEFAULT_LIMITS, Limits
from .model._request import load_request, parse_request
from .model._types import MarkovChannel, PerSensorChannel, Request, Sensor, System
from .stability._verdict import StabilityReport, analyze

# Bounds pull in CVXPY (seconds to import) and simulation is large: both are
# exported lazily so that ``kfio analyze`` starts fast.
_LAZY = {
    "compute_bounds": ".mare",
    "BoundsReport": ".mare",
    "simulate": ".simulation",
    "SimulationReport": ".simulation",
    "expected_covariance": ".simulation",
    "FiniteHorizonReport": ".simulation",
    "SimulationLimits": ".simulation",
    "DEFAULT_SIMULATION_LIMITS": ".simulation",
}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(_LAZY[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'kfio' has no attribute {name!r}")


__all__ = [
    "BoundsReport",
    "DEFAULT_SIMULATION_LIMITS",
    "FiniteHorizonReport",
    "SimulationLimits",
    "SimulationReport",
    "compute_bounds",
    "expected_covariance",
    "simulate",
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
