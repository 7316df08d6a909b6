"""Policy iteration's warm-started evaluations and the remembered ``V_bar`` (kfio.riccati_bounds._riccati).

Above ``DENSE_MAX_N`` states each policy evaluation's GMRES starts from the previous
evaluation; the answer must still be the dense ``vech`` solve's, and ``V_bar`` the one of the
policy iteration without warm starts (the dense route, forced by raising ``DENSE_MAX_N``).
"""

from __future__ import annotations

import numpy as np
import pytest

from kfio.riccati_bounds import _riccati
from kfio.riccati_bounds._gains import normalized_model
from kfio.riccati_bounds._riccati import gains, policy_evaluation, solve_v_bar
from kfio.riccati_bounds._stein import solve_stein
from kfio.riccati_bounds._vech import congruence_matrix, vech

from support.stein_dense import dense


def model(seed: int, n: int, lam: float):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    A *= 1.2 / max(abs(np.linalg.eigvals(A)))
    C = rng.normal(size=(2, n))
    return normalized_model(A, [C], [1 - lam, lam])


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("n", [3, 12, 26])
def test_a_warm_start_gives_the_dense_answer(seed: int, n: int) -> None:
    m = model(seed, n, 0.9)
    V = solve_v_bar(m).matrix
    assert V is not None
    K = gains(V, m)
    terms = _riccati.closed_loop_terms(m, K)
    W = np.eye(n) + sum(w * k @ k.T for w, k in zip(m.weights[1:], K))
    rng = np.random.default_rng(seed)
    for start in (V, V * (1 + 1e-3 * rng.normal(size=V.shape)), np.zeros((n, n))):
        X = solve_stein(terms, [W], [start])
        assert X is not None
        Y = dense(terms, W)
        assert np.linalg.norm(X[0] - Y) <= 1e-9 * np.linalg.norm(Y)


@pytest.mark.parametrize("seed", range(2))
def test_warm_started_policy_iteration_keeps_v_bar(seed: int, monkeypatch) -> None:
    n = 26
    m = model(seed, n, 0.9)
    fast = _riccati._solve_v_bar(m, 1e-12, 200_000, None)
    monkeypatch.setattr(_riccati, "DENSE_MAX_N", 10**6)  # the dense vech solves, no GMRES, no warm start
    slow = _riccati._solve_v_bar(m, 1e-12, 200_000, None)
    assert fast.matrix is not None and slow.matrix is not None
    assert np.linalg.norm(fast.matrix - slow.matrix) <= 1e-9 * np.linalg.norm(slow.matrix)
    assert fast.iterations == slow.iterations
    # every warm-started evaluation is still the evaluation of its gains
    X = policy_evaluation(m, gains(fast.matrix, m), fast.matrix)
    assert X is not None and np.linalg.norm(X - slow.matrix) <= 1e-9 * np.linalg.norm(slow.matrix)


def test_v_bar_is_remembered_and_handed_out_as_copies() -> None:
    m = model(5, 4, 0.8)
    first = solve_v_bar(m)
    assert first.matrix is not None
    first.matrix[0, 0] = np.nan  # a caller writing into its answer must not change the next one
    second = solve_v_bar(m)
    assert second.matrix is not None and np.isfinite(second.matrix).all()
    fresh = _riccati._solve_v_bar(m, 1e-12, 200_000, None)
    assert fresh.matrix is not None and np.array_equal(second.matrix, fresh.matrix)
    assert (second.iterations, second.newton_steps) == (fresh.iterations, fresh.newton_steps)
    # another model, another answer
    other = solve_v_bar(model(5, 4, 0.9))
    assert other.matrix is not None and not np.array_equal(other.matrix, second.matrix)


@pytest.mark.parametrize("seed", range(3))
def test_a_certificate_from_a_nearby_factorization_is_the_dense_solve(seed: int, monkeypatch) -> None:
    """``lyapunov_certificate(..., near)``: GMRES preconditioned by the LU of the operator at a nearby point."""
    import scipy.linalg

    from kfio.riccati_bounds import _certificate
    from kfio.riccati_bounds._certificate import lyapunov_certificate

    n = 26
    m = model(seed, n, 0.95)
    V = solve_v_bar(m).matrix
    assert V is not None
    K = gains(V, m)
    terms = _riccati.closed_loop_terms(m, K)
    nearby = [(w * (1 + 1e-7 * (-1) ** i), M) for i, (w, M) in enumerate(terms)]
    L = np.eye(n * (n + 1) // 2) - sum(w * congruence_matrix(M) for w, M in nearby)
    factor = scipy.linalg.lu_factor(L)
    start = scipy.linalg.lu_solve(factor, vech(np.eye(n)))
    Y = dense(terms, np.eye(n))
    monkeypatch.setattr(_certificate, "solve_stein", None)  # neither fallback may answer
    monkeypatch.setattr(_certificate, "closed_loop_operator", None)
    X = lyapunov_certificate(m, K, (factor, start))
    assert X is not None
    assert np.linalg.norm(X - Y) <= 1e-9 * np.linalg.norm(Y)
