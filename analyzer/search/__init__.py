"""The blind-set search engines behind ``sigma_k`` (Rohr, Marelli and Fu (2014), Lemma 3, Corollary 2).

The closure walk over one packet group (:mod:`_blind`, batched in :mod:`_blind_batch`), the Pareto
search over several sensors (:mod:`_pareto`) and the proof that its front is complete
(:mod:`_pareto_proof`). Used by :mod:`kfio.sigma`; nothing here knows about channels.
"""

from __future__ import annotations

from ._blind import Margins, Objective, SlotSpace, search
from ._blind_batch import enumerate_orbits
from ._cyclic import largest_blind_bound
from ._pareto import FrontBudgetExceeded, PartialFront, pareto_search

__all__ = [
    "FrontBudgetExceeded",
    "Margins",
    "Objective",
    "PartialFront",
    "SlotSpace",
    "enumerate_orbits",
    "largest_blind_bound",
    "pareto_search",
    "search",
]
