"""The reported ``lambda_upper`` is the point where a certificate was re-checked, not a bisection midpoint.

``lambda_upper`` is the upper end of the bracket ``(lower_end, lambda_upper]``: the
stability LMI of Sinopoli et al. (2004), Theorem 5, is proved feasible *at* that
exact arrival probability by a certificate ``(K, X)`` with ``X > 0`` and
``X - L_K(X) > 0`` decided over the rationals.  Reporting the midpoint
``(lower_end + upper) / 2`` instead (the ``lambda-upper-midpoint`` mutants) must fail here.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

import kfio
from kfio.riccati_bounds._certificate import ExactPlant, exact_check
from kfio.riccati_bounds._riccati import pattern_weights
from kfio.riccati_bounds._search import CertifiedSearch

TOL = 1e-6
PLANTS = {
    # Sinopoli et al. (2004), Fig. 3 and Fig. 2
    "2x2": ([[Fraction(5, 4), 0], [1, Fraction(11, 10)]], [[1, 1]]),
    "3x3": ([[Fraction(5, 4), 1, 0], [0, Fraction(9, 10), 7], [0, 0, Fraction(3, 5)]], [[1, 0, 2]]),
}


def _search(name: str, lmi: str) -> tuple[CertifiedSearch, ExactPlant]:
    A, C = PLANTS[name]
    exact = ExactPlant(
        tuple(tuple(Fraction(x) for x in r) for r in A), (tuple(tuple(Fraction(x) for x in r) for r in C),)
    )
    s = CertifiedSearch(np.array(A, float), np.array(C, float), [[0]], exact, lmi=lmi)
    return s, exact


@pytest.mark.parametrize("name", sorted(PLANTS))
@pytest.mark.parametrize("lmi", ["fallback", "always"])
def test_lambda_upper_is_the_certified_end_of_the_bracket(name: str, lmi: str) -> None:
    s, plant = _search(name, lmi)
    ub = s.bisect([Fraction(1)], 0, 0.36, TOL)
    assert ub.value is not None and ub.certificate is not None and ub.lower_end is not None
    # the certificate is about exactly the reported point
    assert ub.certificate.lambdas == (ub.value,)
    # and it re-checks there, exactly, from its own K and X (Theorem 5(b) over Q)
    assert exact_check(plant, pattern_weights([ub.value]), ub.certificate.K, ub.certificate.X)
    # the reported point is the upper end of a bracket no wider than the tolerance
    assert ub.lower_end < ub.value <= ub.lower_end + Fraction(TOL) * 2
    # the bracket starts at the closed-form lower bound 1 - 1/rho(A)^2 = 0.36 (Theorem 3), as passed
    assert ub.lower_end >= Fraction(0.36)


def test_the_bounds_report_carries_the_certified_point() -> None:
    A, C = PLANTS["2x2"]
    b = kfio.bounds(kfio.System(A=A, C=C, Q=[[1, 0], [0, 1]], R=[[1]]), kfio.bernoulli(0.6))
    upper = b.critical[0].upper
    assert upper.certificate.lambdas == (upper.value,)
    assert exact_check(
        ExactPlant(tuple(tuple(Fraction(x) for x in r) for r in A), (tuple(tuple(Fraction(x) for x in r) for r in C),)),
        pattern_weights([upper.value]),
        upper.certificate.K,
        upper.certificate.X,
    )
    # the JSON states the same exact point as "exact" and as the certificate's "at"
    row = b.to_dict()["critical_probability"]["upper"]
    assert row["exact"] == str(upper.value) and row["certificate"]["at"] == [str(upper.value)]
    assert row["value"] == float(upper.value) and row["not_certified_at"] == float(upper.lower_end)
