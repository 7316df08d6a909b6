"""Bounds from the modified algebraic Riccati equation (MARE) and its LMIs.

Sinopoli et al. (2004), Liu and Goldsmith (2004) and Rohr, Marelli and Fu
(2010): critical-probability intervals with exact certificates, ``S_bar``,
``V_bar`` and ``P_hat_N``.  Importing this subpackage imports CVXPY.
"""

from ._compute import compute_bounds
from ._report import BoundsReport

__all__ = ["BoundsReport", "compute_bounds"]
