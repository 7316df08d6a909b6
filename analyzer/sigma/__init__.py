"""``sigma_k`` and the exact rate decisions of Rohr, Marelli and Fu (2014), Theorem 1.

:func:`compute_sigma` (Lemmas 2-3, Corollary 2) on the search engines of :mod:`kfio.search`, and the
exact sign of ``|alpha_k|^2 sigma_k - 1`` (:mod:`_decide`).
"""

from __future__ import annotations

from ._decide import VERDICTS, bernoulli_factor, compare_rate_bernoulli, compare_rate_markov, rho_poly, spectral_radius
from ._sigma import SigmaBracket, SigmaBudgetExceeded, SigmaResult, compute_sigma, period_transfer_matrix

__all__ = [
    "SigmaBracket",
    "SigmaBudgetExceeded",
    "SigmaResult",
    "VERDICTS",
    "rho_poly",
    "bernoulli_factor",
    "compare_rate_bernoulli",
    "compare_rate_markov",
    "compute_sigma",
    "period_transfer_matrix",
    "spectral_radius",
]
