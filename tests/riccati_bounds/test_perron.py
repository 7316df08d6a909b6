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
from kfio.riccati_bounds._perron import CLEAR, PerronRadius, crossing
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


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("n", [2, 3, 5, 9, 16, 30])
def test_perron_radius_matches_dense_eigenvalues(seed: int, n: int) -> None:
    matrices = family(seed, n, 2)
    rho = PerronRadius(matrices)
    for x in (0.3, 0.7, 1.0):
        weights = (1 - x, x)
        expected = dense_radius(weights, matrices)
        assert abs(rho(weights) - expected) <= 1e-11 * max(1.0, expected)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("n,p", [(3, 1), (8, 2), (14, 2), (20, 3)])
def test_crossing_brackets_the_dense_threshold(seed: int, n: int, p: int) -> None:
    matrices = family(seed, n, p)
    lo = critical_lower_bound(spectral_radius(matrices[0]))
    hi = 1.0
    if not dense_radius((0.0, 1.0), matrices) < 1 - CLEAR:
        return  # the gain does not stabilize even with every packet: no crossing to find (checked below)
    c = crossing(lambda x: (1 - x, x), matrices, lo, hi)
    assert c is not None
    assert lo <= c.unstable_at_most < c.stable_from < hi
    # by dense eigenvalues: unstable at the lower confirmed point (unless it is lo), stable at the upper
    assert dense_radius((1 - c.stable_from, c.stable_from), matrices) < 1 - CLEAR / 2
    if c.unstable_at_most > lo:
        assert dense_radius((1 - c.unstable_at_most, c.unstable_at_most), matrices) > 1 + CLEAR / 2
    assert c.decide(c.stable_from) is True and c.decide(c.unstable_at_most) is False
    assert c.decide(0.5 * (c.unstable_at_most + c.stable_from)) is None


def test_crossing_declines_when_the_upper_end_is_not_stable() -> None:
    A = np.diag([1.5, 0.5])
    assert crossing(lambda x: (1 - x, x), [A, A], 0.1, 1.0) is None


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
