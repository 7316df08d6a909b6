"""The exact stability verdict: blind patterns, ``sigma_k``, rates, regions.

Rohr, Marelli and Fu (2014), Theorem 1, and kfio's per-sensor extension.
"""

from ._critical_parameter import CriticalParameter, ParameterConstraint
from ._ge_boundary import boundary_lines
from ._ge_region import Crossing, GeMap, GeRegion, GeStructure, LineResult
from ._regions import RegionGrid, SensorThreshold, SensorThresholds, exact_region_grid
from ._regions_constraints import BlindPattern, BlockConstraints
from ._regions_curve import BoundaryCurve, BoundaryPiece, Envelope, Segment
from ._sensor_gain import SensorGains
from ._sigma import SigmaResult, compute_sigma
from ._tail import BlockTail, TailReport
from ._verdict import BlockReport, StabilityReport, analyze

__all__ = [
    "BlindPattern",
    "BlockConstraints",
    "BlockReport",
    "BlockTail",
    "BoundaryCurve",
    "BoundaryPiece",
    "CriticalParameter",
    "Crossing",
    "Envelope",
    "GeMap",
    "GeRegion",
    "GeStructure",
    "LineResult",
    "ParameterConstraint",
    "RegionGrid",
    "Segment",
    "SensorGains",
    "SensorThreshold",
    "SensorThresholds",
    "SigmaResult",
    "StabilityReport",
    "TailReport",
    "analyze",
    "boundary_lines",
    "compute_sigma",
    "exact_region_grid",
]
