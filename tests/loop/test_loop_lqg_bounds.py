"""Bounds J_min <= J_inf <= J_max on the optimal TCP-like LQG cost (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V).

Checked against closed forms of the scalar Riccati equations and against a Monte Carlo of the
optimal TCP-like loop: the time-varying Kalman filter with intermittent observations and the
stationary gain of the control MARE.  The Monte Carlo also checks the derivation itself: the
cost is tr(S Q) + tr(M E[P(t|t)]) with the *filtered* covariance, not the predicted one.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from kfio.loop import analyze_loop, parse_loop_request


def _body(
    a: str, lam: str, nu: str, b: str = "1", c: str = "1", q: str = "1", r: str = "1", w: str = "1", u: str = "1"
):
    return {
        "system": {"A": [[a]], "B": [[b]], "C": [[c]], "Q": [[q]], "R": [[r]]},
        "channel": {"model": "bernoulli", "arrival_probability": lam},
        "actuator_channel": {"model": "bernoulli", "arrival_probability": nu},
        "controller": {"lqg": {"W": [[w]], "U": [[u]]}},
    }


def _positive_root(qa: float, qb: float, qc: float) -> float:
    return (-qb + math.sqrt(qb * qb - 4 * qa * qc)) / (2 * qa)


def _closed_forms(a, b, c, q, r, w, u, lam, nu):
    """Scalar fixed points: s of the control MARE, v of the estimation MARE, s_bar of the Lyapunov bound.

    s = a^2 s + w - nu a^2 b^2 s^2 / (b^2 s + u)  <=>  b^2 (1 - a^2 + nu a^2) s^2 + (u (1 - a^2) - w b^2) s - w u = 0.
    """
    s = _positive_root(b * b * (1 - a * a + nu * a * a), u * (1 - a * a) - w * b * b, -w * u)
    v = _positive_root(c * c * (1 - a * a + lam * a * a), r * (1 - a * a) - q * c * c, -q * r)
    s_bar = q / (1 - (1 - lam) * a * a)
    m = a * a * s + w - s
    j_min = s * q + m * (1 - lam) * s_bar
    j_max = s * q + m * (v - lam * v * v * c * c / (c * c * v + r))
    return s, j_min, j_max


@pytest.mark.parametrize(
    "a,b,c,q,r,w,u,lam,nu",
    [
        ("1.25", "1", "1", "1", "1", "1", "1", "0.7", "0.6"),
        ("-2", "0.5", "2", "0.3", "1.5", "2", "0.25", "0.9", "0.85"),
    ],
)
def test_scalar_bounds_are_the_papers_closed_forms(a, b, c, q, r, w, u, lam, nu):
    rep = analyze_loop(parse_loop_request(_body(a, lam, nu, b, c, q, r, w, u)))
    out = rep.to_dict()["lqg"]["optimal"]["cost_bounds"]
    s, j_min, j_max = _closed_forms(*(float(x) for x in (a, b, c, q, r, w, u, lam, nu)))
    assert out["S"][0][0] == pytest.approx(s, rel=1e-9)
    assert out["lower"] == pytest.approx(j_min, rel=1e-8)
    assert out["paper_upper"] == pytest.approx(j_max, rel=1e-6)
    assert out["lower"] < out["upper"] <= out["paper_upper"] * (1 + 1e-9)  # P_hat_N is at least as tight as V_bar
    assert out["reason"] is None
    # the optimal design costs no more than the stationary gains kfio analyses exactly
    assert out["lower"] <= rep.cost


def _optimal_tcp_loop(a, b, c, q, r, w, u, lam, nu, rng, trajectories=4000, steps=300):
    """Monte Carlo of the optimal TCP-like loop: per trajectory, the time-averaged stage cost and E-average of P(t|t)."""
    s, _, _ = _closed_forms(a, b, c, q, r, w, u, lam, nu)
    gain = a * b * s / (b * b * s + u)
    x = np.sqrt(q) * rng.standard_normal(trajectories)
    xh, P = np.zeros(trajectories), np.full(trajectories, q)  # x_hat[t|t-1], P[t|t-1]
    cost, p_filtered, p_predicted = (np.zeros(trajectories) for _ in range(3))
    for t in range(steps):
        g = rng.random(trajectories) < lam
        h = rng.random(trajectories) < nu
        y = c * x + np.sqrt(r) * rng.standard_normal(trajectories)
        k = P * c / (c * c * P + r)
        xf = np.where(g, xh + k * (y - c * xh), xh)
        Pf = np.where(g, P - k * c * P, P)
        applied = np.where(h, -gain * xf, 0.0)  # the estimator knows it (TCP-like)
        if t >= steps // 2:
            cost += w * x**2 + u * applied**2
            p_filtered += Pf
            p_predicted += P
        x = a * x + b * applied + np.sqrt(q) * rng.standard_normal(trajectories)
        xh, P = a * xf + b * applied, a * a * Pf + q
    n = steps - steps // 2
    return s, cost / n, p_filtered / n, p_predicted / n


def test_monte_carlo_of_the_optimal_tcp_loop_lies_within_the_bounds_and_obeys_the_formula():
    # lam = 0.7 > 1 - 1/a^4 = 0.59: P(t) has a finite variance, so the confidence interval means something
    a, b, c, q, r, w, u, lam, nu = 1.25, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.7, 0.6
    out = analyze_loop(parse_loop_request(_body("1.25", "0.7", "0.6"))).to_dict()["lqg"]["optimal"]["cost_bounds"]
    s, cost, p_filtered, p_predicted = _optimal_tcp_loop(a, b, c, q, r, w, u, lam, nu, np.random.default_rng(11))
    m = a * a * s + w - s
    mean, se = cost.mean(), cost.std(ddof=1) / math.sqrt(cost.size)
    assert se < 0.02 * mean
    assert out["lower"] - 3.9 * se <= mean <= out["upper"] + 3.9 * se, (out["lower"], mean, se, out["upper"])
    # the derivation: J = tr(S Q) + tr(M E[P(t|t)]) trajectory by trajectory (up to a martingale and boundary terms)
    diff = cost - (s * q + m * p_filtered)
    assert abs(diff.mean()) < 3.9 * diff.std(ddof=1) / math.sqrt(diff.size)
    # and it is the filtered covariance: the predicted one gives a clearly different number
    wrong = (s * q + m * p_predicted).mean()
    assert abs(wrong - mean) > 20 * se


def test_bounds_not_available_name_the_reason():
    # a Gilbert-Elliott sensor channel: kfio's covariance bounds need i.i.d. arrivals; LQG gains are refused first
    from kfio.loop._lqg_bounds import lqg_cost_bounds

    req = parse_loop_request(_body("1.25", "0.7", "0.6"))
    import dataclasses

    from kfio.model import MarkovChannel

    ge = MarkovChannel("gilbert_elliott", 1, (0.5, 0.9), {"failure_rate": 0.1, "recovery_rate": 0.5})
    S = np.array([[1.0]])
    out = lqg_cost_bounds(dataclasses.replace(req, channel=ge), S)
    assert out.lower is None and out.upper is None and out.reason is not None and "Bernoulli" in out.reason
    out = lqg_cost_bounds(dataclasses.replace(req, protocol="udp"), S)
    assert out.lower is None and out.reason is not None and "TCP" in out.reason


def test_nu_c_exact_for_square_b_and_one_input_and_bracketed_otherwise():
    rep = analyze_loop(parse_loop_request(_body("2", "0.9", "0.9"))).to_dict()["lqg"]["optimal"]
    assert rep["critical_actuator"]["is_exact"] and rep["critical_actuator_arrival_probability_exact"] == "3/4"
    assert rep["critical_actuator"]["lower"] == rep["critical_actuator"]["upper"] == 0.75

    def body(B):
        return {
            "system": {
                "A": [["1.2", "1"], ["0", "1.1"]],
                "B": B,
                "C": [["1", "0"]],
                "Q": [["1", "0"], ["0", "1"]],
                "R": [["1"]],
            },
            "channel": {"model": "bernoulli", "arrival_probability": "0.95"},
            "actuator_channel": {"model": "bernoulli", "arrival_probability": "0.95"},
        }

    # one input: Elia's 1 - 1/(1.44 * 1.21) = 464/1089, above the lower bound 1 - 1/rho(A)^2 = 11/36
    one = body([["1"], ["1"]])
    one["controller"] = {"lqg": {"W": [["1", "0"], ["0", "1"]], "U": [["1"]]}}
    out = analyze_loop(parse_loop_request(one)).to_dict()["lqg"]["optimal"]
    assert out["critical_actuator_arrival_probability_exact"] == "464/1089"
    # the same input twice (B square, singular): no closed form here, a certified bracket around 464/1089
    two = body([["1", "1"], ["1", "1"]])
    two["controller"] = {"lqg": {"W": [["1", "0"], ["0", "1"]], "U": [["1", "0"], ["0", "1"]]}}
    out = analyze_loop(parse_loop_request(two)).to_dict()["lqg"]["optimal"]
    crit = out["critical_actuator"]
    assert not crit["is_exact"] and out["critical_actuator_arrival_probability_exact"] is None
    assert crit["lower"] == pytest.approx(1 - 1 / 1.2**2)
    assert crit["upper"] is not None and crit["lower"] <= 464 / 1089 <= crit["upper"] < 0.95
