"""The exact stability verdict of Rohr, Marelli and Fu (2014), Theorem 1, and the report around it.

:func:`analyze` assembles the verdict from :mod:`kfio.sigma` (``sigma_k``, exact rate decisions,
on the blind-set engines of :mod:`kfio.search`) and the design answers of :mod:`kfio.design`; this
face also names their report classes, which is where most callers look for them.
"""

from __future__ import annotations

from ..design import (
    BlindPattern,
    BlockConstraints,
    BlockTail,
    BoundaryCurve,
    BoundaryPiece,
    CriticalParameter,
    Crossing,
    Envelope,
    GeMap,
    GeRegion,
    GeStructure,
    LineResult,
    ParameterConstraint,
    RegionGrid,
    Segment,
    SensorGains,
    SensorThreshold,
    SensorThresholds,
    TailReport,
    boundary_lines,
    exact_region_grid,
)
from ..sigma import SigmaResult, compute_sigma
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
