"""Exact structure of ``A`` seen through ``C``: eigenvalues, Jordan sizes, FMO blocks.

Rohr, Marelli and Fu (2014), Section III: irreducible factors of the
characteristic polynomial over Q, eigenvectors over number fields, FMO classes
(eigenvalues whose ratios are roots of unity) and the reduced blocks in phase form.
"""

from ._adjugate import to_fmpq_mat
from ._algebraic import AlgebraicReal
from ._balls import MAX_PREC, START_PREC, integer_coeffs, precision, root_balls, sign
from ._display import SHORT_TEXT_CHARS, readable, short_text
from ._eigen import DIGITS, EigenFactor, X, eigen_factors
from ._fmo import FmoBlock, fmo_blocks
from ._phases import PhaseBlock, Slot

__all__ = [
    "AlgebraicReal",
    "DIGITS",
    "EigenFactor",
    "FmoBlock",
    "MAX_PREC",
    "PhaseBlock",
    "SHORT_TEXT_CHARS",
    "START_PREC",
    "Slot",
    "X",
    "eigen_factors",
    "fmo_blocks",
    "integer_coeffs",
    "precision",
    "readable",
    "root_balls",
    "short_text",
    "sign",
    "to_fmpq_mat",
]
