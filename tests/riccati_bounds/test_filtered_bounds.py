"""Filtered P(t|t) counterparts of S_bar and V_bar: scalar closed forms, exact enumeration, Monte Carlo."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from kfio import load_request
from kfio.riccati_bounds import compute_bounds
from kfio.simulation import expected_covariance, simulate


def _request(A, C, lam, R=None, sensors=None, channel=None, **sim):
    n, p = len(A), len(C)
    system = {"A": A, "C": C, "Q": np.eye(n).tolist(), "R": R or np.eye(p).tolist()}
    if sensors:
        system["sensors"] = sensors
    return load_request(
        json.dumps(
            {
                "system": system,
                "channel": channel or {"model": "bernoulli", "arrival_probability": lam},
                "options": {"simulate": sim},
            }
        )
    )


@pytest.mark.parametrize(("a", "lam"), [(1.2, 0.6), (0.9, 0.3), (2.0, 0.9)])
def test_scalar_closed_forms(a, lam):
    # V_bar: v = a^2 v + 1 - lam a^2 v^2 / (v + 1); times (v + 1): (1 - a^2 + lam a^2) v^2 - a^2 v - 1 = 0
    A2 = a * a
    c2, c1, c0 = 1 - A2 + lam * A2, -A2, -1.0
    v = (-c1 + math.sqrt(c1 * c1 - 4 * c2 * c0)) / (2 * c2)
    s = 1 / (1 - (1 - lam) * A2)
    d = compute_bounds(_request([[a]], [[1]], lam)).to_dict()["covariance"]
    assert d["V_bar"]["trace"] == pytest.approx(v, rel=1e-8)
    f = d["filtered"]
    assert f["upper"]["trace"] == pytest.approx((1 - lam) * v + lam * v / (v + 1), rel=1e-8)
    assert f["lower"]["trace"] == pytest.approx((1 - lam) * s, rel=1e-8)


def test_upper_bound_holds_at_every_step_of_the_exact_enumeration():
    # with P0 = Q <= V_bar, E[P_t] <= V_t <= V_bar, so E[P(t|t)] <= sum_S pi(S) F_S(V_bar) at every t
    A, C, lam = [[1.1, 0.4], [0.0, 0.8]], [[1.0, 0.5]], 0.7
    up = np.array(compute_bounds(_request(A, C, lam)).to_dict()["covariance"]["filtered"]["upper"]["matrix"])
    ex = expected_covariance(_request(A, C, lam), 14)
    for t in range(15):
        assert np.linalg.eigvalsh(up - ex.filtered_mean_covariance[t])[0] >= -1e-9, t
    # and it is not vacuous: within 15% of the exact filtered trace at the horizon
    assert np.trace(up) < 1.15 * ex.filtered_mean_trace[-1]


def test_long_run_monte_carlo_between_the_filtered_bounds():
    A, C, lam = [[1.1, 0.4], [0.0, 0.8]], [[1.0, 0.5]], 0.7
    f = compute_bounds(_request(A, C, lam)).to_dict()["covariance"]["filtered"]
    rep = simulate(_request(A, C, lam, steps=150, trajectories=6000, seed=2))
    fs = rep.filtered_stats
    m, sem = fs.mean[-40:].mean(), fs.sem[-1]
    assert f["lower"]["trace"] - 2 * sem <= m <= f["upper"]["trace"] + 3 * sem


def test_two_sensors_filtered_upper_is_the_pattern_sum():
    A, C = [[1.2, 0.3], [0.0, 0.7]], [[1.0, 0.0], [0.5, 1.0]]
    sensors = [{"name": "one", "rows": [0]}, {"name": "two", "rows": [1]}]
    channel = {
        "model": "per_sensor",
        "channels": {
            "one": {"model": "bernoulli", "arrival_probability": 0.6},
            "two": {"model": "bernoulli", "arrival_probability": 0.5},
        },
    }
    d = compute_bounds(_request(A, C, None, sensors=sensors, channel=channel)).to_dict()["covariance"]
    V = np.array(d["V_bar"]["matrix"])
    Cm = np.array(C)
    want = np.zeros((2, 2))
    for g1, w1 in ((0, 0.4), (1, 0.6)):
        for g2, w2 in ((0, 0.5), (1, 0.5)):
            rows = [i for i, g in enumerate((g1, g2)) if g]
            if rows:
                info = np.linalg.inv(V) + Cm[rows].T @ Cm[rows]
                want += w1 * w2 * np.linalg.inv(info)
            else:
                want += w1 * w2 * V
    np.testing.assert_allclose(d["filtered"]["upper"]["matrix"], want, rtol=1e-9)
    assert d["filtered"]["lower"]["trace"] == pytest.approx(0.4 * 0.5 * d["S_bar"]["trace"])


def test_p_hat_entries_carry_a_filtered_trace():
    d = compute_bounds(_request([[1.2]], [[1]], 0.6)).to_dict()
    e = d["p_hat"]["entries"]
    for x in e:
        v = x["trace"]
        assert x["filtered_trace"] == pytest.approx(0.4 * v + 0.6 * v / (v + 1), rel=1e-9)
    assert e[-1]["filtered_trace"] <= d["covariance"]["filtered"]["upper"]["trace"] + 1e-12
