"""The exact stability verdict: blind patterns, ``sigma_k``, rates, regions.

Rohr, Marelli and Fu (2014), Theorem 1, and kfio's per-sensor extension.
"""

from ._sigma import SigmaResult, compute_sigma
from ._verdict import StabilityReport, analyze

__all__ = ["SigmaResult", "StabilityReport", "analyze", "compute_sigma"]
