"""The solver-free routes to ``lambda_upper`` (kfio.riccati_bounds._gains) against the LMI and closed forms.

Sources: Sinopoli et al. (2004) Theorem 5 (the equivalence of MARE, gains and LMI
feasibility) and Sec. IV (bounds that coincide), on a plant where the LMI route alone stops short of the
closed form.
"""

from __future__ import annotations

import json
from fractions import Fraction

import numpy as np
import pytest

from kfio import load_request
from kfio.riccati_bounds._certificate import ExactPlant
from kfio.riccati_bounds._compute import compute_bounds, critical_lower_bound
from kfio.riccati_bounds._gains import annihilating_gains, normalized_model, policy_gains, unstable_subspace
from kfio.riccati_bounds._riccati import closed_loop_operator, gains, solve_v_bar, spectral_radius
from kfio.riccati_bounds._search import CertifiedSearch

ISSUE12_A = [["-6/5", 0, "-1/5"], [1, "-2/5", "4/5"], ["3/5", -1, "-4/5"]]
ISSUE12_C = [[-2, -2, -1], [0, -2, -1]]


def exact(M: np.ndarray) -> tuple[tuple[Fraction, ...], ...]:
    return tuple(tuple(Fraction(float(x)) for x in row) for row in M)


def random_system(rng: np.random.Generator, n: int, p: int) -> tuple[np.ndarray, np.ndarray]:
    A = rng.normal(size=(n, n))
    A = np.round(A * 1.3 / max(abs(np.linalg.eigvals(A))), 3)
    return A, np.round(rng.normal(size=(p, n)), 3)


def rho_closed_loop(A, C, K, lam) -> float:
    m = normalized_model(A, [C], [1 - lam, lam])
    return float(max(abs(np.linalg.eigvals(closed_loop_operator(m, K)))))


@pytest.mark.slow
def test_issue12_reproducer_bounds_meet_at_the_closed_form() -> None:
    # C is injective on the 2-dimensional unstable subspace of A, so lambda_upper = lambda_lower = 0.250289
    # (the LMI route alone reported 0.27403 and "not certifiable" at 0.27393).
    body = {
        "system": {"A": ISSUE12_A, "C": ISSUE12_C, "Q": np.eye(3).tolist(), "R": np.eye(2).tolist()},
        "channel": {"model": "bernoulli", "arrival_probability": 0.26},
    }
    rep = compute_bounds(load_request(json.dumps(body)))
    crit = rep.critical[0]
    assert crit.lower == pytest.approx(0.2502886531, abs=1e-9)
    assert crit.lower < float(crit.upper.value) <= crit.lower + 1e-6
    assert crit.upper.certificate.method == "exact_rational"
    assert crit.upper.certificate.route == "annihilating gains"
    assert rep.verdict == "stable"  # 0.26 is above lambda_upper: certified there too
    assert rep.covariance.v_bar.matrix is not None  # V_bar exists at 0.26
    d = rep.to_dict()["critical_probability"]["upper"]
    assert d["certificate"]["gains_from"] == "annihilating gains"


def test_annihilating_gains_zero_the_unstable_subspace_and_meet_the_lower_bound() -> None:
    rng = np.random.default_rng(3)
    checked = 0
    for _ in range(20):
        A, C = random_system(rng, 5, 3)
        U = unstable_subspace(A)
        if not 1 <= U.shape[1] <= 3 or np.linalg.matrix_rank(C @ U) < U.shape[1]:
            continue
        (K,) = annihilating_gains(A, [C])
        assert np.allclose((A + K @ C) @ U, 0, atol=1e-9 * max(1.0, np.abs(K).max()))
        lower = critical_lower_bound(spectral_radius(A))
        # block triangular closed loop: rho(L_K) = max((1 - lam) rho(A)^2, rho(A_stable)^2, ...) < 1 iff lam > lower
        assert rho_closed_loop(A, C, (K,), lower + 1e-3) < 1
        assert rho_closed_loop(A, C, (K,), lower - 1e-3) > 1
        checked += 1
    assert checked >= 5


def test_policy_gains_converge_to_the_gains_of_v_bar() -> None:
    rng = np.random.default_rng(5)
    A, C = random_system(rng, 4, 1)
    lam = 0.9
    model = normalized_model(A, [C], [1 - lam, lam])
    V = solve_v_bar(model).matrix
    (K_star,) = gains(V, model)
    (K0,) = gains(solve_v_bar(normalized_model(A, [C], [0.0, 1.0])).matrix, normalized_model(A, [C], [0.0, 1.0]))
    assert rho_closed_loop(A, C, (K0,), lam) < 1  # the Kalman gains at lambda = 1 stabilize at 0.9 here
    (K,) = policy_gains(model, (K0,))
    assert np.allclose(K, K_star, rtol=1e-7, atol=1e-9)
    assert policy_gains(model, (np.zeros_like(K0),)) is None  # A itself is not stable: no evaluation


@pytest.mark.parametrize("seed", range(4))
def test_solver_free_lambda_upper_agrees_with_the_lmi_bisection(seed) -> None:
    # Sinopoli et al. (2004) Theorem 5: MARE fixed point, stabilizing gains and the LMI exist at the same lambdas, so the
    # continuation (no solver) and the bisection over LMI solves find the same lambda_upper within the tolerance.
    rng = np.random.default_rng(100 + seed)
    A, C = random_system(rng, 5, 1)  # one output, several unstable modes: no annihilating gain
    plant = ExactPlant(exact(A), (exact(C),))
    lower = critical_lower_bound(spectral_radius(A))
    free = CertifiedSearch(A, C, [[0]], plant, lmi="never").bisect([Fraction(1)], 0, lower, 1e-6)
    lmi = CertifiedSearch(A, C, [[0]], plant, lmi="always").bisect([Fraction(1)], 0, lower, 1e-6)
    assert free.certificate.method == lmi.certificate.method == "exact_rational"
    assert free.steps == 0 and lmi.steps > 0
    assert abs(float(free.value) - float(lmi.value)) <= 2e-6
    assert free.lower_end < free.value and float(free.value - free.lower_end) <= 1e-6 + 1e-12
