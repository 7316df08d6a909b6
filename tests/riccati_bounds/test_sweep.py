"""``bound_traces``: the S_bar / V_bar sweep the phase-transition plot draws."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kfio._budget import Budget
from kfio.errors import BudgetExceeded
from kfio.riccati_bounds._sweep import bound_traces

# Sinopoli et al. (2004), Fig. 1 and Fig. 3 systems
SCALAR = (np.array([[-1.25]]), np.array([[1.0]]), np.array([[1.0]]), np.array([[2.5]]))
TWO = (np.array([[1.25, 0.0], [1.0, 1.1]]), np.array([[1.0, 1.0]]), 20 * np.eye(2), np.array([[2.5]]))


def _iterate(step, n: int, steps: int = 200_000) -> float:
    """Plain fixed-point iteration from 0: NaN if it has not settled (the bound does not exist)."""
    X = np.zeros((n, n))
    for _ in range(steps):
        Y = step(X)
        if not np.all(np.isfinite(Y)) or np.trace(Y) > 1e12:
            return math.nan
        if np.max(np.abs(Y - X)) <= 1e-12 * max(1.0, np.max(np.abs(Y))):
            return float(np.trace(Y))
        X = Y
    return math.nan


def _brute(A, C, Q, R, lam: float) -> tuple[float, float]:
    s = _iterate(lambda S: (1 - lam) * A @ S @ A.T + Q, A.shape[0])
    v = _iterate(
        lambda V: A @ V @ A.T + Q - lam * A @ V @ C.T @ np.linalg.inv(C @ V @ C.T + R) @ C @ V @ A.T, A.shape[0]
    )
    return s, v


@pytest.mark.parametrize("system, lams", [(SCALAR, [0.2, 0.37, 0.5, 0.9]), (TWO, [0.3, 0.5, 0.7, 0.95])])
def test_traces_match_plain_iteration(system, lams) -> None:
    t = bound_traces(*system, lams)
    assert t.lambdas.tolist() == lams
    for i, lam in enumerate(lams):
        s, v = _brute(*system, lam)
        if math.isnan(s):
            assert math.isnan(t.s_bar[i])
        else:
            assert t.s_bar[i] == pytest.approx(s, rel=1e-8)
        if not math.isnan(v):
            assert t.v_bar[i] == pytest.approx(v, rel=1e-6)
        if not (math.isnan(t.s_bar[i]) or math.isnan(t.v_bar[i])):
            assert t.s_bar[i] <= t.v_bar[i] * (1 + 1e-12)


def test_s_bar_exists_exactly_above_the_lower_bound() -> None:
    # 1 - 1/1.25^2 = 0.36: (1 - lambda) 1.5625 < 1 iff lambda > 0.36
    t = bound_traces(*SCALAR, [0.3, 0.35, 0.37, 0.4])
    assert np.isnan(t.s_bar[:2]).all() and np.isfinite(t.s_bar[2:]).all()
    # closed form for the scalar case: S = Q / (1 - (1 - lambda) a^2)
    assert t.s_bar[3] == pytest.approx(1 / (1 - 0.6 * 1.5625), rel=1e-12)


def test_v_bar_only_from_the_given_lambda() -> None:
    t = bound_traces(*SCALAR, [0.5, 0.6, 0.7], v_bar_from=0.6)
    assert math.isnan(t.v_bar[0]) and np.isfinite(t.v_bar[1:]).all()
    assert np.isfinite(t.s_bar).all()


def test_budget_is_ticked_per_point() -> None:
    budget = Budget(max_steps=5)
    with pytest.raises(BudgetExceeded, match="S_bar/V_bar sweep"):
        bound_traces(*SCALAR, np.linspace(0.5, 0.9, 10), budget=budget)
