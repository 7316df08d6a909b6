"""Monte Carlo of the intermittent Kalman filter and the exact finite-horizon ``E[P_t]``."""

from ._finite_horizon import FiniteHorizonReport, expected_covariance
from ._setup import DEFAULT_SIMULATION_LIMITS, SimulationLimits
from ._simulate import SimulationReport, simulate

__all__ = [
    "DEFAULT_SIMULATION_LIMITS",
    "FiniteHorizonReport",
    "SimulationLimits",
    "SimulationReport",
    "expected_covariance",
    "simulate",
]
