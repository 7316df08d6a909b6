"""The stability LMI, the V_bar SDP and the certificate re-checks (kfio.riccati_bounds._lmi, bounds_certificate, bounds_search)."""

from __future__ import annotations

from fractions import Fraction

import cvxpy as cp
import numpy as np
import pytest
import scipy.optimize

from kfio.riccati_bounds import _riccati as riccati
from kfio.riccati_bounds._certificate import ExactPlant, certify, exact_check, float_check, lyapunov_certificate
from kfio.riccati_bounds._lmi import StabilityLMI, balancing_scaling
from kfio.riccati_bounds._search import CertifiedSearch
from kfio.riccati_bounds._vbar_sdp import v_bar_sdp

THREE_Q = (
    (Fraction(5, 4), Fraction(1), Fraction(0)),
    (Fraction(0), Fraction(9, 10), Fraction(7)),
    (0, 0, Fraction(3, 5)),
)
THREE_A = np.array([[1.25, 1, 0], [0, 0.9, 7], [0, 0, 0.6]])
THREE_C = np.array([[1.0, 0, 2]])
TWO_A = np.array([[1.25, 0], [1, 1.1]])
TWO_C = np.array([[1.0, 1.0]])


def exact(M) -> tuple[tuple[Fraction, ...], ...]:
    return tuple(tuple(Fraction(x) if not isinstance(x, float) else Fraction(str(x)) for x in row) for row in M)


def plant_one(A, C) -> ExactPlant:
    return ExactPlant(exact(A), (exact(C),))


def search_one(A, C, **kw) -> CertifiedSearch:
    return CertifiedSearch(A, C, [list(range(C.shape[0]))], plant_one(A, C), **kw)


def test_lmi_is_dpp_and_has_the_theorem5_size() -> None:
    lmi = StabilityLMI(3, [1])
    assert lmi.is_dpp()
    assert lmi.size == 9  # [Y, sqrt(lam)(YA + ZC), sqrt(1-lam) YA] over three block rows
    assert StabilityLMI(2, [1, 1, 2]).size == 2 * 5  # Liu and Goldsmith (2004) eq. 20: 2^2 + 1 blocks


def test_balancing_scaling_is_powers_of_two_and_balances() -> None:
    d = balancing_scaling(THREE_A)
    assert np.all(np.log2(d) == np.round(np.log2(d)))
    B = np.diag(1 / d) @ THREE_A @ np.diag(d)
    assert np.abs(B).max() < np.abs(THREE_A).max()


def test_lmi_gains_certify_above_and_fail_below_the_threshold() -> None:
    s = search_one(THREE_A, THREE_C)
    cert = s.certify([Fraction(1, 2)])
    assert cert is not None and cert.method == "exact_rational" and cert.margin > 0
    assert s.certify([Fraction(3, 10)]) is None  # below lambda_lower = 0.36 nothing can be feasible


def test_exact_check_accepts_a_true_certificate_and_rejects_false_ones() -> None:
    lam = Fraction(1, 2)
    weights = riccati.pattern_weights([lam])
    model = riccati.ArrivalModel(THREE_A, np.zeros((3, 3)), (THREE_C,), (np.zeros((1, 1)),), tuple(map(float, weights)))
    K = search_one(THREE_A, THREE_C).certify([lam]).K
    X = lyapunov_certificate(model, K)
    plant = ExactPlant(THREE_Q, (exact(THREE_C),))
    assert exact_check(plant, weights, K, X)
    assert float_check(model, K, X) is not None
    assert not exact_check(plant, weights, K, -X)  # X must be positive definite
    K0 = (np.zeros((3, 1)),)  # open loop: (1 - 1/2) * 1.25^2 + 1/2 * 1.25^2 > 1
    assert not exact_check(plant, weights, K0, X)
    assert certify(model, plant, [lam], weights, K0, None) is None


def test_exact_check_sees_what_rounding_hides() -> None:
    # A = 1 - 2^-60 is exact in the request but rounds to 1.0 as a float: with nothing arriving,
    # X - A X A' = (1 - A^2) X ~ 2^-59 X > 0 holds over Q while the float residual is exactly 0.
    a = 1 - Fraction(1, 2**60)
    assert float(a) == 1.0
    plant = ExactPlant(((a,),), ((Fraction(1),),))
    weights = [Fraction(1), Fraction(0)]  # nothing ever arrives
    X, K = np.array([[1.0]]), (np.zeros((1, 1)),)
    assert exact_check(plant, weights, K, X)
    model = riccati.ArrivalModel(
        np.array([[float(a)]]), np.zeros((1, 1)), (np.eye(1),), (np.zeros((1, 1)),), (1.0, 0.0)
    )
    assert float_check(model, K, X) is None
    assert not exact_check(ExactPlant(((Fraction(1),),), ((Fraction(1),),)), weights, K, X)  # A = 1: 0 is not > 0


@pytest.mark.parametrize("recenter", [True, False])
def test_coinciding_bounds_within_1e4_on_seed004_3x3(recenter) -> None:
    # Sinopoli et al. (2004) Sec. IV, "A has a single unstable eigenvalue": lambda_c = 0.36 and the bounds coincide.
    s = search_one(THREE_A, THREE_C, recenter=recenter)
    ub = s.bisect([Fraction(1)], 0, 0.36, 1e-6)
    assert ub.certificate.method == "exact_rational"
    assert 0.36 < float(ub.value) < 0.36 + 1e-4


def min_closed_loop_radius(A, C, lam, starts=40, seed=0) -> float:
    """``min_K rho((1-lam) A(x)A + lam F(x)F)``, ``F = A + K C``, by Nelder-Mead from many starts (non-convex)."""
    rng = np.random.default_rng(seed)
    n, p = A.shape[0], C.shape[0]

    def rho(k):
        F = A + k.reshape(n, p) @ C
        return max(abs(np.linalg.eigvals((1 - lam) * np.kron(A, A) + lam * np.kron(F, F))))

    best = np.inf
    for _ in range(starts):
        r = scipy.optimize.minimize(
            rho,
            rng.normal(scale=2, size=n * p),
            method="Nelder-Mead",
            options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 4000},
        )
        best = min(best, r.fun)
    return best


@pytest.mark.slow
def test_lambda_upper_of_seed004_2x2_by_an_independent_route() -> None:
    # Sinopoli et al. (2004) Fig. 3 / Rohr, Marelli and Fu (2010) Sec. VI: A = [[1.25, 0], [1, 1.1]], C = [1 1]; Rohr, Marelli and Fu (2010) reads lambda_upper ~ 0.48.
    # The LMI is feasible iff some K makes L_K(X) = (1-lam) A X A' + lam F X F' Schur stable (Sinopoli et al. (2004) Thm 5(b)),
    # so minimizing rho(L_K) over K directly (no LMI, no solver) must cross 1 at the same lambda: 0.47107.
    ub = search_one(TWO_A, TWO_C).bisect([Fraction(1)], 0, 0.36, 1e-6)
    lam_up = float(ub.value)
    assert lam_up == pytest.approx(0.471075, abs=2e-6)
    assert min_closed_loop_radius(TWO_A, TWO_C, lam_up + 1e-3) < 1
    assert min_closed_loop_radius(TWO_A, TWO_C, lam_up - 1e-3) > 1


@pytest.mark.parametrize(
    "A,C,Q,R,lam",
    [
        (np.array([[-1.25]]), np.array([[1.0]]), np.eye(1), np.array([[2.5]]), 0.4),
        (THREE_A, THREE_C, 20 * np.eye(3), np.array([[2.5]]), 0.4),
        (TWO_A, TWO_C, 20 * np.eye(2), np.array([[2.5]]), 0.5),
        (TWO_A, TWO_C, 20 * np.eye(2), np.array([[2.5]]), 1.0),
    ],
)
def test_v_bar_sdp_agrees_with_the_iteration(A, C, Q, R, lam) -> None:
    model = riccati.one_packet_model(A, C, Q, R, lam)
    V = riccati.solve_v_bar(model).matrix
    sdp = v_bar_sdp(model)
    assert sdp.status == cp.OPTIMAL
    assert np.linalg.norm(sdp.matrix - V) <= 1e-6 * np.linalg.norm(V)


def test_v_bar_sdp_two_packets_agrees_with_the_iteration() -> None:
    # Liu and Goldsmith (2004) eq. 21 (Case 1 system of Sec. VI-A) at (lambda_1, lambda_2) = (0.3, 0.4).
    A = TWO_A
    C = np.array([[1.0, 0], [0, 1], [1, 0], [1, 1]])
    model = riccati.arrival_model(A, C, 20 * np.eye(2), 2.5 * np.eye(4), [[0, 1], [2, 3]], [0.3, 0.4])
    V = riccati.solve_v_bar(model).matrix
    sdp = v_bar_sdp(model)
    assert np.linalg.norm(sdp.matrix - V) <= 1e-6 * np.linalg.norm(V)


def test_seed004_theorem6_block_without_q_is_a_typo() -> None:
    # As printed: [[A V A' - V, sqrt(lam) A V C'], [., C V C' + R]] >= 0. Without Q it is not V_bar (Liu and Goldsmith (2004) has Q).
    A, C, R, lam = np.array([[-1.25]]), np.array([[1.0]]), np.array([[2.5]]), 0.4
    V = cp.Variable((1, 1), symmetric=True)
    s = np.sqrt(lam)
    G = cp.bmat([[A @ V @ A.T - V, s * A @ V @ C.T], [s * C @ V @ A.T, C @ V @ C.T + R]])
    prob = cp.Problem(cp.Maximize(cp.trace(V)), [0.5 * (G + G.T) >> 0, V >> 0])
    prob.solve(solver=cp.CLARABEL)
    with_q = riccati.v_bar(A, C, np.eye(1), R, lam)[0, 0]  # 39.51
    assert prob.status != cp.OPTIMAL or abs(prob.value - with_q) > 1.0


def test_two_packet_search_matches_seed000_case1_closed_form() -> None:
    # Liu and Goldsmith (2004) Sec. VI-A Case 1: C_1 = I, C_2 = [[1, 0], [1, 1]] both invertible, lambda_2c = max(0, 1 - 1/(1.25^2 (1 - lambda_1))).
    C = np.array([[1.0, 0], [0, 1], [1, 0], [1, 1]])
    Cq = exact(C)
    groups = [[0, 1], [2, 3]]
    rows = riccati.subset_rows(groups)
    plant = ExactPlant(exact(TWO_A), tuple(tuple(Cq[r] for r in rs) for rs in rows))
    s = CertifiedSearch(TWO_A, C, groups, plant)
    for l1 in (Fraction(0), Fraction(1, 5)):
        closed = max(0.0, 1 - 1 / (1.5625 * (1 - float(l1))))
        ub = s.bisect([l1, Fraction(0)], 1, closed, 1e-6)
        assert closed < float(ub.value) <= closed + 1e-4
