"""Exact structure of ``A`` seen through ``C``: eigenvalues, Jordan sizes, FMO blocks.

Rohr, Marelli and Fu (2014), Section III: irreducible factors of the
characteristic polynomial over Q, eigenvectors over number fields, FMO classes
(eigenvalues whose ratios are roots of unity) and the reduced blocks in phase form.
"""

from ._eigen import EigenFactor, eigen_factors
from ._fmo import FmoBlock, fmo_blocks

__all__ = ["EigenFactor", "FmoBlock", "eigen_factors", "fmo_blocks"]
