"""Monte Carlo of the intermittent Kalman filter and the exact finite-horizon ``E[P_t]``."""

from ..model import packets_of
from ._finite_horizon import FiniteHorizonReport, expected_covariance
from ._outage_target import OutageTarget
from ._setup import DEFAULT_SIMULATION_LIMITS, PERCENTILES, SimulationLimits, matrix_or_none, parse_options
from ._simulate import SimulationReport, simulate
from ._stationary import Z95, StationaryReport, verdict_headline

__all__ = [
    "DEFAULT_SIMULATION_LIMITS",
    "FiniteHorizonReport",
    "OutageTarget",
    "PERCENTILES",
    "SimulationLimits",
    "SimulationReport",
    "StationaryReport",
    "Z95",
    "expected_covariance",
    "matrix_or_none",
    "packets_of",
    "parse_options",
    "simulate",
    "verdict_headline",
]
