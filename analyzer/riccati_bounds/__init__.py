"""Bounds from the modified algebraic Riccati equation (MARE) and its LMIs.

Sinopoli et al. (2004), Liu and Goldsmith (2004) and Rohr, Marelli and Fu
(2010): critical-probability intervals with exact certificates, ``S_bar``,
``V_bar`` and ``P_hat_N``.  Importing this subpackage imports CVXPY.
"""

from ._certificate import StabilityCertificate
from ._compute import compute_bounds
from ._continuation import FixedPoint, mare_fixed_point
from ._filtered import FilteredBounds
from ._options import parse_bounds_options
from ._report import BoundsReport, CovarianceBounds, CriticalInterval, PHatBounds, RegionMap
from ._sweep import bound_traces
from ._targets import TraceTarget

__all__ = [
    "BoundsReport",
    "CovarianceBounds",
    "CriticalInterval",
    "FilteredBounds",
    "FixedPoint",
    "PHatBounds",
    "RegionMap",
    "StabilityCertificate",
    "TraceTarget",
    "bound_traces",
    "compute_bounds",
    "mare_fixed_point",
    "parse_bounds_options",
]
