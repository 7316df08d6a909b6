"""The low-rank generalized Stein solver (kfio.riccati_bounds._stein) against the dense vech solve."""

from __future__ import annotations

import numpy as np
import pytest

from kfio.riccati_bounds._stein import MIN_N, solve_dense, solve_low_rank, solve_stein


def case(seed: int, n: int, rows: list[int]):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    A *= rng.uniform(0.8, 1.3) / max(abs(np.linalg.eigvals(A)))
    C = [rng.normal(size=(p, n)) for p in rows]
    K = [-A @ c.T @ np.linalg.inv(c @ c.T + np.eye(p)) * rng.uniform(0.5, 1.0) for c, p in zip(C, rows)]
    w = rng.dirichlet(np.ones(len(rows) + 1))
    B = rng.normal(size=(n, n))
    return A, K, C, [float(x) for x in w], [np.eye(n), B @ B.T]


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("n,rows", [(3, [1]), (8, [2]), (12, [1, 1, 2]), (20, [2])])
def test_low_rank_agrees_with_dense(seed: int, n: int, rows: list[int]) -> None:
    A, K, C, w, rhs = case(seed, n, rows)
    terms = [(w[0], A)] + [(wi, A + k @ c) for wi, k, c in zip(w[1:], K, C)]
    dense = solve_dense(terms, rhs)
    fast = solve_low_rank(A, K, C, w, rhs)
    assert dense is not None
    assert fast is not None  # these cases are well conditioned: the residual check must pass
    for X, Y in zip(fast, dense):
        assert np.linalg.norm(X - Y) <= 1e-9 * np.linalg.norm(Y)
        assert np.array_equal(X, X.T)


def test_declines_below_min_n_and_answers_above() -> None:
    A, K, C, w, rhs = case(0, 5, [1])
    assert solve_stein(A, K, C, w, rhs) is None
    A, K, C, w, rhs = case(1, MIN_N, [2])
    X = solve_stein(A, K, C, w, rhs)
    terms = [(w[0], A)] + [(wi, A + k @ c) for wi, k, c in zip(w[1:], K, C)]
    Y = solve_dense(terms, rhs)
    assert X is not None and Y is not None
    assert np.linalg.norm(X[0] - Y[0]) <= 1e-9 * np.linalg.norm(Y[0])


def test_single_term_is_bartels_stewart() -> None:
    # No low-rank part (every pattern weight on A alone): the Schur recursion alone must solve it.
    A, _, _, _, rhs = case(2, 10, [1])
    X = solve_low_rank(0.5 * A, [], [], [1.0], rhs)
    assert X is not None
    for Xk, W in zip(X, rhs):
        assert np.linalg.norm(Xk - 0.25 * A @ Xk @ A.T - W) <= 1e-12 * np.linalg.norm(Xk)
