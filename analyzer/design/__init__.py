"""Design answers beside the verdict: tail exponents, Gilbert-Elliott regions, critical parameters,
per-sensor regions and sensor improvement (kfio's extensions of Rohr, Marelli and Fu (2014) and
Mo and Sinopoli (2012); docs/design-answers.md and docs/regions.md say which is a theorem).
"""

from __future__ import annotations

from ._critical_parameter import CriticalParameter, ParameterConstraint, channel_parameter, critical_parameter
from ._design_options import analyze_options
from ._ge_boundary import boundary_lines
from ._ge_region import Crossing, GeMap, GeRegion, GeStructure, LineResult, ge_region
from ._regions import RegionGrid, SensorThreshold, SensorThresholds, exact_region_grid, region_report
from ._regions_constraints import BlindPattern, BlockConstraints
from ._regions_curve import BoundaryCurve, BoundaryPiece, Envelope, Segment
from ._sensor_gain import SensorGains
from ._tail import BlockTail, TailReport, tail_kappa, tail_report

__all__ = [
    "BlindPattern",
    "BlockConstraints",
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
    "TailReport",
    "analyze_options",
    "boundary_lines",
    "channel_parameter",
    "critical_parameter",
    "exact_region_grid",
    "ge_region",
    "region_report",
    "tail_kappa",
    "tail_report",
]
