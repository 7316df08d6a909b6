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

# Bounds pull in CVXPY (seconds to import) and simulation is large: both are
# exported lazily so that ``kfio analyze`` starts fast.
_LAZY = {
    "compute_bounds": ".bounds",
    "BoundsReport": ".bounds_report",
    "simulate": ".simulate",
    "SimulationReport": ".simulate",
    "expected_covariance": ".finite_horizon",
    "FiniteHorizonReport": ".finite_horizon",
    "SimulationLimits": ".sim_setup",
    "DEFAULT_SIMULATION_LIMITS": ".sim_setup",
}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(_LAZY[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'analyzer' has no attribute {name!r}")


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
