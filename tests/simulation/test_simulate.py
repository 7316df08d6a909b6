"""Monte Carlo simulation: agreement with the exact E[P_t], reproducibility, options, overflow."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from kfio import InvalidInput, LimitExceeded
from kfio._budget import Budget
from kfio.errors import BudgetExceeded
from kfio.simulation._finite_horizon import expected_covariance
from kfio.simulation._kernel import GroupedRiccatiStep, RiccatiStep
from kfio.simulation._setup import SimulationLimits, parse_options, sim_system
from kfio.simulation._simulate import run_monte_carlo, simulate

from support.factories import bern, ge, make

SEED004 = {
    "A": [[1.25, 1, 0], [0, 0.9, 7], [0, 0, 0.6]],
    "C": [[1, 0, 2]],
    "Q": [[20, 0, 0], [0, 20, 0], [0, 0, 20]],
    "R": [[2.5]],
}
TWO_SENSORS = {
    "A": [[1.25, 0], [1, 1.1]],
    "C": [[1, 0], [1, 1], [0, 1]],
    "Q": [[20, 0], [0, 20]],
    "R": [[2.5, 0.5, 0], [0.5, 2, 0.25], [0, 0.25, 1]],
    "sensors": [{"name": "a", "rows": [0, 2]}, {"name": "b", "rows": [1]}],
}


CHANNELS = {
    "bernoulli": ({"A": [[-1.25]], "C": [[1]], "Q": [[1]], "R": [[2.5]]}, bern(0.5)),
    "gilbert_elliott": (SEED004, ge(0.3, 0.6)),
    "markov_order_2": (
        {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]], "Q": [[20, 0], [0, 20]], "R": [[2.5]]},
        {"model": "markov", "order": 2, "arrival_probability": {"00": 0.3, "01": 0.6, "10": 0.5, "11": 0.8}},
    ),
    "per_sensor": (TWO_SENSORS, {"model": "per_sensor", "channels": {"a": ge(0.2, 0.5), "b": bern(0.6)}}),
}


@pytest.mark.parametrize("name", sorted(CHANNELS))
def test_monte_carlo_mean_agrees_with_exact(name: str) -> None:
    """Two independent routes to E[trace P_t], t <= 8: sampling vs. enumeration.

    20 000 trajectories; at every step the exact value must lie within 4.5 standard errors of the
    sample mean (a fixed seed makes this deterministic; 4.5 sigma keeps it robust to the seed).
    """
    system, channel = CHANNELS[name]
    steps = 8 if name != "per_sensor" else 6
    req = make(system, channel, {"steps": steps, "trajectories": 20_000, "seed": 7, "exact_steps": steps})
    rep = simulate(req)
    exact = rep.exact.mean_trace
    z = np.abs(rep.mean_trace - exact)[1:] / rep.stats.sem[1:]
    assert np.all(z < 4.5), z
    agree = rep.exact_agreement()
    assert agree["steps_compared"] == steps + 1
    assert agree["within_ci95"] >= steps - 2  # about 95% of the steps lie within the band
    # The sampler's arrival frequencies match the stationary rates: over 20 000 x steps >= 1.2e5 draws the
    # binomial sd is <= 0.0015, at most doubled by the correlation of Markov arrivals; 0.01 is >= 3 sd.
    assert np.all(np.abs(rep.arrival_rate - rep.stationary_arrival_rate) < 0.01)


@pytest.mark.parametrize("how", ["all_lost", "all_arrived"])
def test_initial_channel_options_agree_with_exact(how: str) -> None:
    system, channel = CHANNELS["gilbert_elliott"]
    req = make(system, channel, {"steps": 6, "trajectories": 20_000, "seed": 3, "initial_channel": how})
    rep = simulate(req)
    exact = expected_covariance(req, 6).mean_trace
    assert np.all(np.abs(rep.mean_trace - exact)[1:] < 4.5 * rep.stats.sem[1:])
    # starting from "all lost" the first packet arrives w.p. q = 0.6, from "all arrived" w.p. 1 - p = 0.7
    assert exact[1] != pytest.approx(expected_covariance(make(system, channel), 6).mean_trace[1])


def test_same_seed_same_report_and_other_seed_differs() -> None:
    system, channel = CHANNELS["per_sensor"]
    a = simulate(make(system, channel, {"steps": 30, "trajectories": 500, "seed": 11}))
    b = simulate(make(system, channel, {"steps": 30, "trajectories": 500, "seed": 11}))
    c = simulate(make(system, channel, {"steps": 30, "trajectories": 500, "seed": 12}))
    assert json.dumps(a.to_dict()) == json.dumps(b.to_dict())
    assert a.to_dict()["mean_trace"] != c.to_dict()["mean_trace"]


def test_masked_and_grouped_updates_agree() -> None:
    system, channel = CHANNELS["per_sensor"]
    req = make(system, channel, {"steps": 25, "trajectories": 300, "seed": 5})
    sim, opts = sim_system(req), parse_options(req)
    masked = run_monte_carlo(sim, opts)
    grouped = run_monte_carlo(sim, opts, update=GroupedRiccatiStep(sim.A, sim.Q, sim.C, sim.R))
    np.testing.assert_allclose(grouped.stats.mean, masked.stats.mean, rtol=1e-9)
    np.testing.assert_allclose(grouped.final_mean_covariance, masked.final_mean_covariance, rtol=1e-9)


def test_update_is_exactly_symmetric_and_matches_textbook() -> None:
    rng = np.random.default_rng(0)
    A = np.array([[1.25, 1, 0], [0, 0.9, 7], [0, 0, 0.6]])
    C, Q, R = np.array([[1.0, 0, 2], [0, 1, 1]]), 20 * np.eye(3), np.array([[2.5, 0.3], [0.3, 1.0]])
    X = rng.standard_normal((50, 3, 3))
    P = X @ np.swapaxes(X, 1, 2)
    P = (P + np.swapaxes(P, 1, 2)) / 2
    mask = (rng.random((50, 2)) < 0.5).astype(float)
    out = RiccatiStep.build(A, Q, C, R)(P, mask)
    assert np.array_equal(out, np.swapaxes(out, 1, 2))
    for k in range(50):
        r = np.flatnonzero(mask[k])
        Ck, Rk = C[r], R[np.ix_(r, r)]
        ref = A @ P[k] @ A.T + Q
        if r.size:
            ref -= A @ P[k] @ Ck.T @ np.linalg.inv(Ck @ P[k] @ Ck.T + Rk) @ Ck @ P[k] @ A.T
        np.testing.assert_allclose(out[k], ref, rtol=1e-10, atol=1e-10 * np.abs(ref).max())


def test_overflow_marks_trajectories_and_reports_null() -> None:
    # a = 1e30, lambda = 1/2: open-loop runs multiply trace by 1e60 per step; many overflow quickly.
    req = make({"A": [["1e30"]], "C": [[1]], "Q": [[1]], "R": [[1]]}, bern("1/2"), {"steps": 40, "trajectories": 200})
    rep = simulate(req)
    d = rep.to_dict()
    text = json.dumps(d, allow_nan=False)  # no NaN/inf anywhere
    assert d["diverged"] is True and d["mean_diverged_at"] is not None
    t0 = d["mean_diverged_at"]
    assert d["mean_trace"][t0 - 1] is not None and all(x is None for x in d["mean_trace"][t0:])
    assert d["ci95_low"][t0] is None and d["final_mean_covariance"] is None
    assert d["diverged_trajectories"] > 0
    # the median stays finite for a while after the first overflow (the mean does not)
    assert d["percentile_diverged_at"]["50"] is None or d["percentile_diverged_at"]["50"] > t0
    assert "diverged at t" in rep.summary() and "null" in text


def test_report_shape_and_defaults() -> None:
    system, channel = CHANNELS["bernoulli"]
    rep = simulate(make(system, channel, {"steps": 50}))
    d = rep.to_dict()
    assert d["trajectories"] == 10_000 and d["seed"] == 0 and d["P0"] == "Q"
    assert d["initial_channel"] == "stationary"
    assert len(d["mean_trace"]) == 51 and set(d["percentiles"]) == {"50", "90", "99"}
    for t in range(51):
        assert d["ci95_low"][t] <= d["mean_trace"][t] <= d["ci95_high"][t]
        assert d["percentiles"]["50"][t] <= d["percentiles"]["90"][t] <= d["percentiles"]["99"][t]
    assert d["exact"] is None and d["checks"]["exact_agreement"] is None
    assert "Monte Carlo: 10000 trajectories x 50 steps" in rep.summary()
    # 200 steps by default: the trajectory count shrinks to fit 10^6 trajectory-steps
    assert parse_options(make(system, channel)).trajectories == 5_000


def test_given_p0_is_used() -> None:
    system, channel = CHANNELS["bernoulli"]
    rep = simulate(make(system, channel, {"steps": 3, "trajectories": 10, "P0": [["7/2"]]}))
    assert rep.mean_trace[0] == 3.5 and rep.to_dict()["P0"] == [[3.5]]


@pytest.mark.parametrize(
    ("options", "field", "match"),
    [
        ({"stepz": 3}, "/options/simulate/stepz", "unknown option"),
        ({"steps": 0}, "/options/simulate/steps", "at least 1"),
        ({"steps": 10_001}, "/options/simulate/steps", "at most 10000"),
        ({"steps": 2.5}, "/options/simulate/steps", "integer"),
        ({"steps": True}, "/options/simulate/steps", "integer"),
        ({"trajectories": 1}, "/options/simulate/trajectories", "at least 2"),
        ({"steps": 1000, "trajectories": 1001}, "/options/simulate/trajectories", "exceeds the limit 1000000"),
        ({"seed": -1}, "/options/simulate/seed", "at least 0"),
        ({"seed": "1"}, "/options/simulate/seed", "integer"),
        ({"exact_steps": 21}, "/options/simulate/exact_steps", "2\\^21"),
        ({"initial_channel": "random"}, "/options/simulate/initial_channel", "one of"),
        ({"percentiles": [50, 95]}, "/options/simulate/percentiles", "fixed"),
        ({"P0": [[1, 2], [3, 4]]}, "/options/simulate/P0", "must be 1x1"),
        ({"P0": [[-1]]}, "/options/simulate/P0", "positive semidefinite"),
        ({"P0": "Q"}, "/options/simulate/P0", "array"),
    ],
)
def test_bad_options_name_their_field(options: dict, field: str, match: str) -> None:
    system, channel = CHANNELS["bernoulli"]
    with pytest.raises(InvalidInput, match=match) as err:
        simulate(make(system, channel, options))
    assert err.value.field == field


def test_limits_are_configurable_and_over_limit_is_limit_exceeded() -> None:
    system, channel = CHANNELS["bernoulli"]
    req = make(system, channel, {"steps": 100, "trajectories": 100})
    small = SimulationLimits(max_trajectory_steps=5_000)
    with pytest.raises(LimitExceeded, match="exceeds the limit 5000"):
        simulate(req, limits=small)
    big = make(system, channel, {"steps": 10, "trajectories": 200_000})
    assert simulate(big, limits=SimulationLimits(max_trajectory_steps=2_000_000)).options.trajectories == 200_000
    wide = make(
        {"A": np.eye(40).tolist(), "C": [[1] * 40], "Q": np.eye(40).tolist(), "R": [[1]]},
        bern(0.5),
        {"steps": 1, "trajectories": 30_000},
    )
    with pytest.raises(LimitExceeded, match="floats"):
        simulate(wide)


def test_missing_noise_covariances() -> None:
    for missing, field in (("Q", "/system/Q"), ("R", "/system/R")):
        system = {k: v for k, v in CHANNELS["bernoulli"][0].items() if k != missing}
        with pytest.raises(InvalidInput) as err:
            simulate(make(system, bern(0.5)))
        assert err.value.field == field


def test_budget_is_honoured() -> None:
    system, channel = CHANNELS["bernoulli"]
    req = make(system, channel, {"steps": 100, "trajectories": 1000})
    with pytest.raises(BudgetExceeded):
        simulate(req, budget=Budget(max_steps=10_000))


def test_assumption_1_violations_still_simulate() -> None:
    # lambda = 0 (never arrives): open loop, trace P_t = sum a^(2k) exactly, no randomness
    req = make({"A": [[0.5]], "C": [[1]], "Q": [[1]], "R": [[1]]}, bern(0), {"steps": 5, "trajectories": 4})
    rep = simulate(req)
    expected = [sum(0.25**k for k in range(t + 1)) for t in range(6)]
    np.testing.assert_allclose(rep.mean_trace, expected, rtol=1e-14)
    assert rep.percentile(99)[5] == pytest.approx(expected[5]) and math.isclose(rep.stats.std[5], 0.0, abs_tol=1e-15)
