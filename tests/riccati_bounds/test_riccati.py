"""Riccati, Lyapunov and P_hat_N maps (kfio.riccati_bounds._riccati, kfio.riccati_bounds._phat).

Four kinds of checks: substitute-back (residuals), closed forms worked by hand,
agreement between independent routes (SciPy's DARE, a literal transcription
of Liu and Goldsmith (2004) eq. 12, a per-sequence recursion of Rohr, Marelli and Fu (2010) eq. 4), and the
monotonicity facts the seeds prove (Sinopoli et al. (2004) Lemma 1, Rohr, Marelli and Fu (2010) Theorem 1).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from kfio.errors import NumericalFailure
from kfio.riccati_bounds import _riccati as riccati
from kfio.riccati_bounds._phat import BatchedMare, max_horizon, p_hat, p_hat_sequence
from kfio.riccati_bounds._vech import unvech, vech

SCALAR = (np.array([[-1.25]]), np.array([[1.0]]), np.array([[1.0]]), np.array([[2.5]]))
THREE = (np.array([[1.25, 1, 0], [0, 0.9, 7], [0, 0, 0.6]]), np.array([[1.0, 0, 2]]), 20 * np.eye(3), np.array([[2.5]]))
TWO = (np.array([[1.25, 0], [1, 1.1]]), np.array([[1.0, 1.0]]), 20 * np.eye(2), np.array([[2.5]]))
#: Two outputs in one packet, to exercise the p > 1 branch (Cholesky) of the batched map.
TWO_OUT = (
    np.array([[1.2, 0.3], [0.0, 0.7]]),
    np.array([[1.0, 0.0], [0.5, 1.0]]),
    np.eye(2),
    np.array([[1.0, 0.2], [0.2, 2.0]]),
)


def psd_order(small: np.ndarray, big: np.ndarray, rel: float = 1e-9) -> bool:
    """``small <= big`` in the PSD order, up to ``rel * ||big||``."""
    return bool(np.linalg.eigvalsh(big - small)[0] >= -rel * np.linalg.norm(big, 2))


# --- g, S_bar, V_bar ------------------------------------------------------------------------


def test_s_bar_scalar_closed_form() -> None:
    # S = 0.6 * 1.5625 S + 1  =>  S = 1 / (1 - 0.9375) = 16
    A, _, Q, _ = SCALAR
    assert riccati.s_bar(A, Q, 0.6)[0, 0] == pytest.approx(16.0, rel=1e-14)


def test_s_bar_substitutes_back_and_is_none_past_the_threshold() -> None:
    A, _, Q, _ = THREE
    S = riccati.s_bar(A, Q, 0.6)
    assert riccati.lyapunov_residual(S, A, Q, 0.6) < 1e-12
    assert riccati.s_bar(A, Q, 0.64) is None  # 0.64 * 1.25^2 = 1: the Lyapunov operator is not stable
    assert riccati.s_bar(A, Q, 0.7) is None


@pytest.mark.parametrize("system,lam", [(SCALAR, 0.4), (THREE, 0.4), (TWO, 0.5), (TWO_OUT, 0.6)])
def test_v_bar_is_a_fixed_point_of_the_mare(system, lam) -> None:
    A, C, Q, R = system
    V = riccati.v_bar(A, C, Q, R, lam)
    assert V is not None
    scale = np.linalg.norm(V)
    assert np.linalg.norm(riccati.g_lambda(V, A, C, Q, R, lam) - V) <= 1e-11 * scale
    assert np.allclose(V, V.T)
    assert np.linalg.eigvalsh(V)[0] > 0  # Sinopoli et al. (2004) Lemma 1(g)


@pytest.mark.parametrize("system", [SCALAR, THREE, TWO, TWO_OUT])
def test_v_bar_at_lambda_one_is_the_kalman_dare(system) -> None:
    # Every packet arrives: the MARE is the ordinary filter Riccati equation (Sinopoli et al. (2004), proof of Theorem 2).
    A, C, Q, R = system
    P = scipy.linalg.solve_discrete_are(A.T, C.T, Q, R)
    np.testing.assert_allclose(riccati.v_bar(A, C, Q, R, 1.0), P, rtol=1e-9)


def test_v_bar_scalar_value_by_the_quadratic_formula() -> None:
    # Scalar MARE: V = a^2 V + q - lam a^2 V^2 / (V + r)  <=>  (1 - a^2 (1 - lam)) V^2 + (r(1 - a^2) - q) V - q r = 0.
    a2, q, r, lam = 1.5625, 1.0, 2.5, 0.4
    qa, qb, qc = 1 - a2 * (1 - lam), r * (1 - a2) - q, -q * r
    root = (-qb + np.sqrt(qb * qb - 4 * qa * qc)) / (2 * qa)
    A, C, Q, R = SCALAR
    assert riccati.v_bar(A, C, Q, R, lam)[0, 0] == pytest.approx(root, rel=1e-12)


def test_v_bar_is_none_below_the_lower_bound() -> None:
    A, C, Q, R = THREE
    assert riccati.v_bar(A, C, Q, R, 0.3) is None
    assert riccati.v_bar(A, C, Q, R, 0.36) is None  # (1 - lam) rho^2 = 1 exactly
    res = riccati.solve_v_bar(riccati.one_packet_model(A, C, Q, R, 0.3))
    assert res.matrix is None and "S_bar diverges" in res.reason


def test_v_bar_is_none_when_the_iteration_diverges_between_the_bounds() -> None:
    # The 2x2 system of Sinopoli et al. (2004) Fig. 3: lambda_upper ~ 0.471 > 0.45 > 0.36 = lambda_lower.
    A, C, Q, R = TWO
    res = riccati.solve_v_bar(riccati.one_packet_model(A, C, Q, R, 0.45))
    assert res.matrix is None and "diverges" in res.reason


def test_v_bar_iteration_brackets_the_fixed_point() -> None:
    A, C, Q, R = THREE
    res = riccati.solve_v_bar(riccati.one_packet_model(A, C, Q, R, 0.37))  # near the threshold: slow from below
    assert res.matrix is not None and res.residual < 1e-12
    assert psd_order(res.lower, res.matrix)  # g^k(0) <= V_bar <= policy-iteration iterate


@pytest.mark.parametrize("system,lam", [(SCALAR, 0.4), (THREE, 0.4), (TWO, 0.5)])
def test_s_bar_below_v_bar(system, lam) -> None:
    # Sinopoli et al. (2004) Theorem 4: S_bar <= lim E[P_t] <= V_bar.
    A, C, Q, R = system
    assert psd_order(riccati.s_bar(A, Q, 1 - lam), riccati.v_bar(A, C, Q, R, lam))


def test_policy_evaluation_is_an_upper_bound_of_v_bar() -> None:
    A, C, Q, R = THREE
    model = riccati.one_packet_model(A, C, Q, R, 0.5)
    V = riccati.v_bar(A, C, Q, R, 0.5)
    K = riccati.gains(V + np.eye(3), model)  # any stabilizing gains
    X = riccati.policy_evaluation(model, K)
    assert X is not None and psd_order(V, X)
    assert riccati.policy_evaluation(model, (np.zeros((3, 1)),)) is None  # open loop at 0.5 is not stable


# --- the partial-loss map (Liu and Goldsmith (2004)) ----------------------------------------------------------


def seed000_eq12(X, A, C1, C2, Q, R, l1, l2):
    """Liu and Goldsmith (2004) eq. 12 transcribed literally (two packets)."""
    C = np.vstack([C1, C2])
    m1 = C1.shape[0]
    R11, R22 = R[:m1, :m1], R[m1:, m1:]

    def term(Cs, Rs):
        return A @ X @ Cs.T @ np.linalg.solve(Cs @ X @ Cs.T + Rs, Cs @ X @ A.T)

    return A @ X @ A.T + Q - l1 * l2 * term(C, R) - l1 * (1 - l2) * term(C1, R11) - (1 - l1) * l2 * term(C2, R22)


def test_g_partial_matches_seed000_eq12() -> None:
    rng = np.random.default_rng(3)
    A = rng.normal(size=(3, 3))
    C = rng.normal(size=(3, 3))
    B = rng.normal(size=(3, 3))
    R = B @ B.T + np.eye(3)  # correlated noise across packets: R_12 != 0
    Q = np.eye(3)
    X = np.eye(3) + 0.1 * np.ones((3, 3))
    model = riccati.arrival_model(A, C, Q, R, [[0], [1, 2]], [0.3, 0.8])
    expect = seed000_eq12(X, A, C[:1], C[1:], Q, R, 0.3, 0.8)
    np.testing.assert_allclose(riccati.g_partial(X, model), expect, rtol=1e-12)


def test_pattern_weights_sum_to_one_and_are_exact_with_fractions() -> None:
    from fractions import Fraction

    w = riccati.pattern_weights([Fraction(1, 3), Fraction(1, 4), Fraction(1, 2)])
    assert sum(w) == 1 and w[0] == Fraction(2, 3) * Fraction(3, 4) * Fraction(1, 2) and w[7] == Fraction(1, 24)


def test_one_packet_model_is_the_mare() -> None:
    A, C, Q, R = THREE
    X = np.diag([3.0, 2.0, 1.0])
    direct = A @ X @ A.T + Q - 0.4 * A @ X @ C.T @ np.linalg.inv(C @ X @ C.T + R) @ C @ X @ A.T
    np.testing.assert_allclose(riccati.g_lambda(X, A, C, Q, R, 0.4), direct, rtol=1e-13)


_small = st.floats(-1.5, 1.5, allow_nan=False)


@settings(max_examples=40, deadline=None)
@given(
    a=st.lists(_small, min_size=4, max_size=4),
    x=st.lists(_small, min_size=4, max_size=4),
    d=st.lists(_small, min_size=4, max_size=4),
    lam=st.floats(0, 1),
    lam2=st.floats(0, 1),
)
def test_g_is_monotone_in_x_and_decreasing_in_lambda(a, x, d, lam, lam2) -> None:
    # Sinopoli et al. (2004) Lemma 1(c) and 1(d); Liu and Goldsmith (2004) Lemmas 2-3.
    A = np.array(a).reshape(2, 2)
    C = np.array([[1.0, 0.5]])
    Q, R = np.eye(2), np.array([[1.0]])
    Bx, Bd = np.array(x).reshape(2, 2), np.array(d).reshape(2, 2)
    X = Bx @ Bx.T
    Y = X + Bd @ Bd.T
    gX, gY = riccati.g_lambda(X, A, C, Q, R, lam), riccati.g_lambda(Y, A, C, Q, R, lam)
    assert psd_order(gX, gY, 1e-9)
    lo, hi = sorted((lam, lam2))
    assert psd_order(riccati.g_lambda(Y, A, C, Q, R, hi), riccati.g_lambda(Y, A, C, Q, R, lo), 1e-9)


# --- Rohr, Marelli and Fu (2010): g_N and P_hat_N ---------------------------------------------------------------


def g_n_by_recursion(X, A, C, Q, R, lam, N):
    """Rohr, Marelli and Fu (2010) eqs. 4 and 11, one arrival sequence at a time (the naive route)."""
    total = np.zeros_like(X)
    for seq in itertools.product((0, 1), repeat=N):
        P, prob = X, 1.0
        for g in seq:
            prob *= lam if g else 1 - lam
            P = riccati.g_lambda(P, A, C, Q, R, float(g))
        total += prob * P
    return total


@pytest.mark.parametrize("system,lam", [(SCALAR, 0.4), (THREE, 0.4), (TWO_OUT, 0.6)])
@pytest.mark.parametrize("N", [1, 2, 5])
def test_batched_g_n_equals_the_per_sequence_recursion(system, lam, N) -> None:
    A, C, Q, R = system
    X = riccati.v_bar(A, C, Q, R, lam)
    op = BatchedMare(A, C, Q, R, lam)
    got = unvech(op.g_n(vech(X), N), A.shape[0])
    np.testing.assert_allclose(got, g_n_by_recursion(X, A, C, Q, R, lam, N), rtol=1e-11)


def test_batched_g_n_with_chunking_equals_without(monkeypatch) -> None:
    import kfio.riccati_bounds._phat as bp

    A, C, Q, R = THREE
    X = riccati.v_bar(A, C, Q, R, 0.4)
    op = BatchedMare(A, C, Q, R, 0.4)
    whole = op.g_n(vech(X), 9)
    monkeypatch.setattr(bp, "CHUNK_LEVELS", 3)  # force the depth-first split
    np.testing.assert_allclose(op.g_n(vech(X), 9), whole, rtol=1e-13)


def test_p_hat_one_is_v_bar_and_p_hat_is_a_fixed_point() -> None:
    A, C, Q, R = THREE
    np.testing.assert_allclose(p_hat(A, C, Q, R, 0.4, 1), riccati.v_bar(A, C, Q, R, 0.4))
    P4 = p_hat(A, C, Q, R, 0.4, 4)
    back = unvech(BatchedMare(A, C, Q, R, 0.4).g_n(vech(P4), 4), 3)
    assert np.linalg.norm(back - P4) <= 1e-9 * np.linalg.norm(P4)


@pytest.mark.parametrize("system,lam", [(SCALAR, 0.4), (THREE, 0.4), (TWO, 0.5), (TWO_OUT, 0.6)])
def test_p_hat_monotone_subsequences(system, lam) -> None:
    # Rohr, Marelli and Fu (2010) Theorem 1, eq. 18: P_hat_{cN} <= P_hat_N <= P_hat_1.
    A, C, Q, R = system
    seq = p_hat_sequence(A, C, Q, R, lam, [1, 2, 3, 4, 6, 8])
    for N, cN in [(1, 2), (2, 4), (4, 8), (1, 3), (3, 6), (2, 6), (1, 8)]:
        assert psd_order(seq[cN].matrix, seq[N].matrix, 1e-10), (N, cN)


def test_p_hat_scalar_improvement_at_20_matches_seed002() -> None:
    # Rohr, Marelli and Fu (2010), Section VI-A, system (35) at lambda = 0.4: "the improvement of P_hat_20 over P_hat_1 is 12%".
    # We find 12.13% (trace 39.5123 -> 34.7181); cross-checked in tests/test_bounds.py against the report.
    A, C, Q, R = SCALAR
    seq = p_hat_sequence(A, C, Q, R, 0.4, [1, 20])
    improvement = 1 - seq[20].matrix[0, 0] / seq[1].matrix[0, 0]
    assert improvement == pytest.approx(0.1213, abs=5e-4)
    assert seq[20].start == 10  # warm start along the divisor chain 20 <- 10 <- 5 <- 1


def test_p_hat_raises_where_it_does_not_exist() -> None:
    A, C, Q, R = SCALAR
    with pytest.raises(NumericalFailure, match="P_hat_2"):
        p_hat(A, C, Q, R, 0.2, 2)


def test_max_horizon_limits() -> None:
    assert [max_horizon(n) for n in (1, 2, 3, 4)] == [20, 20, 20, 20]
    assert max_horizon(5) == 18 and max_horizon(10) == 15 and max_horizon(40) == 7
