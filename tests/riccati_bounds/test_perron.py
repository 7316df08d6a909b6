"""The Perron root that guides the slide's bisection (kfio.riccati_bounds._perron) against dense eigenvalues.

The reference spectral radius is ``max |eig|`` of the ``vech`` matrix ``sum_i w_i T(M_i)``
(``T`` from :func:`kfio.riccati_bounds._vech.congruence_matrix`, itself checked against the
Kronecker form in test_vech.py), computed by LAPACK.  The search guided by the crossing must
return the same certified point as the plain bisection, which solves at every point.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from kfio.riccati_bounds import _search
from kfio.riccati_bounds._certificate import ExactPlant
from kfio.riccati_bounds._compute import critical_lower_bound
from kfio.riccati_bounds._perron import PerronRadius, estimate_crossing
from kfio.riccati_bounds._riccati import spectral_radius
from kfio.riccati_bounds._search import CertifiedSearch
from kfio.riccati_bounds._vech import congruence_matrix


def dense_radius(weights, matrices) -> float:
    L = sum(w * congruence_matrix(M) for w, M in zip(weights, matrices) if w > 0)
    return float(max(abs(np.linalg.eigvals(L))))


def family(seed: int, n: int, p: int):
    """``A`` with ``rho(A)`` about 1.2 and a gain that stabilizes it when the packet arrives."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    A *= 1.2 / max(abs(np.linalg.eigvals(A)))
    C = rng.normal(size=(p, n))
    K = -A @ C.T @ np.linalg.inv(C @ C.T + np.eye(p))
    return [A, A + K @ C]


@pytest.mark.parametrize("n", [2, 3, 5, 9, 16, 30])
def test_perron_radius_matches_dense_eigenvalues(n: int) -> None:
    """A radius it returns is right; where ARPACK finds another eigenvalue first it says so (rarely)."""
    answered = 0
    for seed in range(3):
        matrices = family(seed, n, 2)
        rho = PerronRadius(matrices)
        for x in (0.3, 0.7, 1.0):
            weights = (1 - x, x)
            expected = dense_radius(weights, matrices)
            try:
                got = rho(weights)
            except ArithmeticError:
                continue
            answered += 1
            assert abs(got - expected) <= 1e-8 * max(1.0, expected)  # ARPACK to EIGS_TOL = 1e-10
    assert answered >= 7


def dense_crossing(matrices, lo: float, hi: float) -> float:
    """Bisection on dense eigenvalues to 1e-13 (assumes one crossing)."""
    a, b = lo, hi
    while b - a > 1e-13:
        c = 0.5 * (a + b)
        a, b = (a, c) if dense_radius((1 - c, c), matrices) < 1 else (c, b)
    return b


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("n,p", [(3, 1), (8, 2), (14, 2), (20, 3)])
def test_estimated_crossing_matches_the_dense_threshold(seed: int, n: int, p: int) -> None:
    matrices = family(seed, n, p)
    lo, hi = critical_lower_bound(spectral_radius(matrices[0])), 1.0
    if not dense_radius((0.0, 1.0), matrices) < 1:
        assert estimate_crossing(lambda x: (1 - x, x), matrices, lo, hi) is None
        return
    t = estimate_crossing(lambda x: (1 - x, x), matrices, lo, hi)
    assert t is not None
    expected = dense_crossing(matrices, lo, hi)
    assert abs(t - expected) <= 1e-8


def test_a_crossing_at_or_below_lo_is_lo() -> None:
    A = np.diag([1.5, 0.5])
    F = np.diag([0.0, 0.5])  # the gain annihilates the unstable mode: rho = (1 - x) 2.25 crosses 1 at x = 5/9
    assert estimate_crossing(lambda x: (1 - x, x), [A, F], 0.6, 1.0) == 0.6
    assert estimate_crossing(lambda x: (1 - x, x), [A, A], 0.1, 1.0) is None  # unstable at hi


def random_search(seed: int, n: int) -> tuple[CertifiedSearch, float]:
    """The bench's random system (entries with 3 decimals, ``rho(A)`` about 1.2, two outputs in one packet)."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    A = np.round(A * 1.2 / max(abs(np.linalg.eigvals(A))), 3)
    C = np.round(rng.normal(size=(2, n)), 3)

    def exact(M):
        return tuple(tuple(Fraction(repr(float(x))) for x in r) for r in M)

    plant = ExactPlant(exact(A), (exact(C),))
    return CertifiedSearch(A, C, [[0, 1]], plant), critical_lower_bound(spectral_radius(A))


@pytest.mark.parametrize("seed,n", [(0, 5), (1, 8), (2, 12), (3, 12)])
def test_guided_search_returns_the_plain_bisection_s_point(seed: int, n: int, monkeypatch) -> None:
    monkeypatch.setattr(_search, "PERRON_MIN_N", 0)
    results = []
    for guided in (True, False):
        search, lower = random_search(seed, n)
        search.perron = guided
        ub = search.bisect([Fraction(1)], 0, lower, 1e-6)
        results.append((ub.value, ub.lower_end, search.routes))
        assert (search.guided > 0) == guided
    assert results[0] == results[1]
    assert results[0][0] is not None


@pytest.mark.slow
def test_guided_search_at_26_states_returns_the_plain_bisection_s_point() -> None:
    results = []
    for guided in (True, False):
        search, lower = random_search(0, 26)
        search.perron = guided
        ub = search.bisect([Fraction(1)], 0, lower, 1e-6)
        results.append((ub.value, ub.lower_end))
        assert (search.guided > 0) == guided
    assert results[0] == results[1]
