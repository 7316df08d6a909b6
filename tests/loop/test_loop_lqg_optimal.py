"""LQG answered as the literature answers it (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V).

``lqg.optimal`` is the optimal TCP-like controller: bounded cost iff the sensor link is above
the optimal filter's critical value (Rohr, Marelli and Fu 2014, Theorem 1) and the actuator link
above the control MARE's, ``1 - 1/prod|unstable eigenvalues|^2`` for one input (Elia 2005).
Below either the answer is the verdict ``unstable`` without gains (exit 1, HTTP 200), never
invalid input.  Just above, the Riccati fixed points exist and are found (no iteration cap): each
is substituted back into its equation here.  Elia's formula is checked against an independent
search over static feedbacks for random single-input plants.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
import scipy.optimize
from fastapi.testclient import TestClient

from kfio.errors import InvalidInput
from kfio.loop import analyze_loop, parse_loop_request
from kfio.loop._lqg_critical import known_critical, schur_stable, unstable_modulus_product
from kfio.service.cli import main as cli_main
from kfio.service.settings import Settings

from support.app_client import ready_client

TWO_A = [["5/4", "1"], ["0", "11/10"]]
TWO_B = [["0"], ["1"]]


def _scalar(a: str, lam: str, nu: str, q: str = "1", r: str = "1", w: str = "1", u: str = "1") -> dict:
    return {
        "system": {"A": [[a]], "B": [["1"]], "C": [["1"]], "Q": [[q]], "R": [[r]]},
        "channel": {"model": "bernoulli", "arrival_probability": lam},
        "actuator_channel": {"model": "bernoulli", "arrival_probability": nu},
        "controller": {"lqg": {"W": [[w]], "U": [[u]]}},
    }


def _two(lam: str, nu: str) -> dict:
    eye = [["1", "0"], ["0", "1"]]
    return {
        "system": {"A": TWO_A, "B": TWO_B, "C": eye, "Q": eye, "R": eye},
        "channel": {"model": "bernoulli", "arrival_probability": lam},
        "actuator_channel": {"model": "bernoulli", "arrival_probability": nu},
        "controller": {"lqg": {"W": eye, "U": [["1"]]}},
    }


def _text(x: Fraction) -> str:
    return f"{x.numerator}/{x.denominator}"


def _report(body: dict) -> dict:
    return analyze_loop(parse_loop_request(body)).to_dict()


def _control_residual(report: dict, body: dict) -> float:
    """``||A'SA + W - nu A'SB (B'SB + U)^-1 B'SA - S|| / ||S||`` for the report's ``S``, in this test's own float code."""
    f = lambda m: np.array([[float(Fraction(x)) for x in row] for row in m])  # noqa: E731
    A, B = f(body["system"]["A"]), f(body["system"]["B"])
    W, U = f(body["controller"]["lqg"]["W"]), f(body["controller"]["lqg"]["U"])
    nu = float(Fraction(body["actuator_channel"]["arrival_probability"]))
    S = np.array(report["lqg"]["optimal"]["cost_bounds"]["S"])
    rhs = A.T @ S @ A + W - nu * A.T @ S @ B @ np.linalg.solve(B.T @ S @ B + U, B.T @ S @ A)
    return float(np.linalg.norm(rhs - S) / np.linalg.norm(S))


def test_scalar_critical_values_are_exactly_eleven_over_thirty_six():
    # A = 1.2, B = C = 1: both critical values are 1 - 1/1.44 = 11/36
    out = _report(_scalar("1.2", "0.9", "0.9"))["lqg"]["optimal"]
    assert out["verdict"] == "stable" and out["reasons"] == []
    assert out["critical_sensor_arrival_probability_exact"] == "11/36"
    assert out["critical_actuator_arrival_probability_exact"] == "11/36"
    assert out["critical_actuator"]["is_exact"] and out["critical_actuator_arrival_probability"] == 11 / 36
    assert out["statement"].startswith("the optimal TCP-like LQG needs sensor > 11/36 and actuator > 11/36; ")


def test_single_input_critical_value_is_elias_fifty_seven_over_one_hundred_twenty_one():
    out = _report(_two("0.9", "0.9"))["lqg"]["optimal"]
    # unstable eigenvalues 5/4 and 11/10: 1 - 1/(25/16 * 121/100) = 57/121, not 1 - 1/rho(A)^2 = 9/25
    assert out["critical_actuator_arrival_probability_exact"] == "57/121"
    assert "Elia 2005" in out["critical_actuator"]["from"]
    assert out["critical_sensor_arrival_probability_exact"] == "9/25"  # C = I: 1 - 1/rho(A)^2


@pytest.mark.parametrize(
    "body, why",
    [
        (
            _scalar("1.2", "0.3", "0.9"),
            "sensor arrival probability 3/10 is not above the optimal filter's critical value 11/36",
        ),
        (_scalar("1.2", "0.9", "0.3"), "actuator arrival probability 3/10 is not above its critical value 11/36"),
        (_two("0.9", _text(Fraction(57, 121) - Fraction(1, 1000))), "is not above its critical value 57/121"),
    ],
    ids=["sensor-below", "actuator-below", "single-input-below"],
)
def test_below_the_optimal_critical_values_the_verdict_is_unstable_without_gains(body, why):
    rep = _report(body)
    assert rep["verdict"] == "unstable" and rep["cost"] is None and rep["cost_exact"] is None
    assert rep["loop"]["estimator"] is None and rep["loop"]["feedback"] is None
    assert rep["lqg"]["stationary_gains"]["exist"] is False
    opt = rep["lqg"]["optimal"]
    assert opt["verdict"] == "unstable" and any(why in r for r in opt["reasons"]), opt["reasons"]
    assert any("Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007" in n for n in rep["notes"])
    assert any(why in n for n in rep["notes"])


@pytest.mark.parametrize(
    "body",
    [
        _scalar("1.2", "0.9", _text(Fraction(11, 36) + Fraction(1, 1000))),
        _scalar("1.2", _text(Fraction(11, 36) + Fraction(1, 1000)), "0.9"),
        _two("0.9", _text(Fraction(57, 121) + Fraction(1, 1000))),
        # the seed plant (A = -1.25, C = 1, Q = 1, R = 2.5) used dually: nu_c = 9/25 = 0.36
        _scalar("-1.25", "0.9", "0.3601", w="1", u="2.5"),
        _scalar("-1.25", "0.9", "0.3605", w="1", u="2.5"),
    ],
    ids=["actuator-just-above", "sensor-just-above", "single-input-just-above", "0.3601", "0.3605"],
)
def test_just_above_the_critical_values_the_fixed_points_exist_and_satisfy_their_equations(body):
    rep = _report(body)
    assert rep["lqg"]["optimal"]["verdict"] == "stable"
    assert rep["lqg"]["stationary_gains"]["exist"] and rep["loop"]["feedback"] is not None
    assert _control_residual(rep, body) < 1e-9
    for solve in ("control_riccati", "estimation_riccati"):
        assert rep["lqg"]["stationary_gains"][solve]["relative_residual"] < 1e-9


def test_near_the_critical_value_the_fixed_point_grows_like_its_closed_form():
    # scalar control MARE with b = w = 1, u = 2.5: (1 - a^2 + nu a^2) s^2 + (u (1 - a^2) - w) s - w u = 0
    a, w, u = -1.25, 1.0, 2.5
    for nu in ("0.3601", "0.3605"):
        s_report = _report(_scalar("-1.25", "0.9", nu, w="1", u="2.5"))["lqg"]["optimal"]["cost_bounds"]["S"][0][0]
        qa, qb, qc = 1 - a * a + float(nu) * a * a, u * (1 - a * a) - w, -w * u
        s = (-qb + np.sqrt(qb * qb - 4 * qa * qc)) / (2 * qa)
        assert s_report == pytest.approx(s, rel=1e-8) and s > 1000


@pytest.mark.parametrize(
    "a, lam, nu, r, u",
    [("1.25", "0.8", "0.9", "0.5", "0.5"), ("-2", "0.9", "0.85", "1.5", "0.25"), ("1.1", "0.7", "0.6", "1", "1")],
)
def test_filter_form_costs_the_papers_j_max_and_predictor_form_more(a, lam, nu, r, u):
    body = _scalar(a, lam, nu, r=r, u=u)
    body["cost"] = {"W": [["1"]], "U": [[u]]}
    rep = _report(body)
    assert rep["loop"]["form"] == "filter"
    j_max = rep["lqg"]["optimal"]["cost_bounds"]["paper_upper"]
    assert rep["cost"] == pytest.approx(j_max, rel=1e-9)
    pred = _report({**body, "controller": {**body["controller"], "form": "predictor"}})
    assert pred["loop"]["form"] == "predictor" and pred["cost"] > rep["cost"] * (1 + 1e-3)


def test_the_example_gains_cost_the_papers_j_max_in_filter_form():
    body = json.loads((Path(__file__).resolve().parents[2] / "examples" / "loop_lqg.json").read_text())
    rep = _report(body)
    bounds = rep["lqg"]["optimal"]["cost_bounds"]
    assert bounds["lower"] <= bounds["upper"] <= rep["cost"] == pytest.approx(bounds["paper_upper"], rel=1e-9)


@pytest.mark.parametrize("mode", ["2", "1", "-1"])
def test_an_uncontrollable_unstable_mode_is_told_that_no_probability_helps(mode):
    # |theta| >= 1 out of B's reach, the unit circle included: that mode evolves as theta whatever the input
    eye = [["1", "0"], ["0", "1"]]
    body = {
        "system": {"A": [[mode, "0"], ["0", "1/2"]], "B": [["0"], ["1"]], "C": [["1", "0"]], "Q": eye, "R": [["1"]]},
        "channel": {"model": "bernoulli", "arrival_probability": "0.99"},
        "actuator_channel": {"model": "bernoulli", "arrival_probability": "1"},
        "controller": {"lqg": {"W": eye, "U": [["1"]]}},
    }
    rep = _report(body)
    opt = rep["lqg"]["optimal"]
    assert rep["verdict"] == "unstable" and rep["cost"] is None
    assert opt["critical_actuator_arrival_probability"] is None and opt["critical_actuator"]["stabilizable"] is False
    assert any("uncontrollable unstable mode" in r and "no actuator arrival probability" in r for r in opt["reasons"])
    # the same plant with B reaching that mode: its critical value is 1 - 1/theta^2
    body["system"]["B"] = [["1"], ["0"]]
    theta = Fraction(mode)
    expected = max(Fraction(0), 1 - 1 / theta**2)
    out = _report(body)["lqg"]["optimal"]["critical_actuator_arrival_probability_exact"]
    assert out == (str(expected) if expected.denominator == 1 else _text(expected))


def test_an_unobservable_unstable_mode_is_told_that_no_sensor_probability_helps():
    eye = [["1", "0"], ["0", "1"]]
    body = {
        "system": {"A": [["2", "0"], ["0", "1/2"]], "B": eye, "C": [["0", "1"]], "Q": eye, "R": [["1"]]},
        "channel": {"model": "bernoulli", "arrival_probability": "0.99"},
        "actuator_channel": {"model": "bernoulli", "arrival_probability": "0.99"},
        "controller": {"lqg": {"W": eye, "U": eye}},
    }
    opt = _report(body)["lqg"]["optimal"]
    assert opt["verdict"] == "unstable" and opt["critical_sensor_arrival_probability"] is None
    assert any("unobservable unstable mode" in r for r in opt["reasons"])


def test_form_is_validated_beside_lqg():
    body = {**_scalar("1.2", "0.9", "0.9"), "controller": {"lqg": {"W": [[1]], "U": [[1]]}, "form": "smith"}}
    with pytest.raises(InvalidInput) as err:
        parse_loop_request(body)
    assert err.value.field == "/controller/form"


# --- Elia's formula against the equation --------------------------------------------------------


def _min_radius(A: np.ndarray, b: np.ndarray, nu: float, rng: np.random.Generator) -> float:
    """``min over L of rho(nu F x F + (1 - nu) A x A)``, ``F = A - b L``: a mean-square stabilizing L exists iff < 1."""
    n = A.shape[0]
    lost = (1 - nu) * np.kron(A, A)

    def rho(ell: np.ndarray) -> float:
        F = A - b @ ell.reshape(1, n)
        return float(np.max(np.abs(np.linalg.eigvals(nu * np.kron(F, F) + lost))))

    # deadbeat-like starts (A - b L nilpotent by Ackermann) and random ones
    starts = [np.linalg.lstsq(b, A, rcond=None)[0].ravel()] + [rng.normal(size=n) * 3 for _ in range(5)]
    best = min(rho(s) for s in starts)
    for s in starts:
        res = scipy.optimize.minimize(
            rho, s, method="Nelder-Mead", options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 4000}
        )
        best = min(best, float(res.fun))
    return best


def _random_single_input_plant(rng: np.random.Generator) -> tuple[list[list[Fraction]], list[list[Fraction]]]:
    while True:
        A = [[Fraction(int(rng.integers(-12, 13)), 8) for _ in range(2)] for _ in range(2)]
        B = [[Fraction(int(rng.integers(-2, 3)))] for _ in range(2)]
        Af = np.array(A, dtype=float)
        eig = np.abs(np.linalg.eigvals(Af))
        ctrb = np.column_stack([np.array(B, dtype=float), Af @ np.array(B, dtype=float)])
        if eig.max() > 1.05 and np.linalg.matrix_rank(ctrb) == 2 and eig.max() < 2.5:
            return A, B


@pytest.mark.slow  # four bisections over feedback searches: about 5 s together
@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_elias_formula_agrees_with_a_bisection_on_the_existence_of_a_stabilizing_feedback(seed):
    rng = np.random.default_rng(seed)
    A, B = _random_single_input_plant(rng)
    crit = known_critical(tuple(map(tuple, A)), tuple(map(tuple, B)))
    assert crit is not None and crit.is_exact and crit.value is not None
    # Elia's product by floats, independently of the exact route (rational, or a certified algebraic enclosure)
    eig = np.linalg.eigvals(np.array(A, dtype=float))
    prod = float(np.prod([abs(z) ** 2 for z in eig if abs(z) > 1]))
    nu_c = float(crit.exact_value) if crit.exact_value is not None else crit.value
    assert nu_c == pytest.approx(1 - 1 / prod, rel=1e-12)
    if crit.exact_value is None:
        lo_q, hi_q = crit.enclosure
        assert lo_q <= Fraction(1 - 1 / prod).limit_denominator(10**12) + Fraction(1, 10**9) and hi_q - lo_q < Fraction(
            1, 10**60
        )
    Af, bf = np.array(A, dtype=float), np.array(B, dtype=float)
    lo, hi = 0.0, 1.0
    while hi - lo > 2e-3:
        mid = (lo + hi) / 2
        if _min_radius(Af, bf, mid, rng) < 1:
            hi = mid
        else:
            lo = mid
    assert lo - 5e-3 <= nu_c <= hi + 5e-3, (lo, hi, crit.exact)
    # and kfio's Riccati solver finds the control MARE's fixed point just above it, not below
    from kfio.riccati_bounds import mare_fixed_point

    eye = np.eye(2)
    above = mare_fixed_point(Af.T, bf.T, eye, np.eye(1), nu_c + 2e-3)
    below = mare_fixed_point(Af.T, bf.T, eye, np.eye(1), nu_c - 2e-3)
    assert above.matrix is not None and above.residual < 1e-9 and below.matrix is None


def test_the_exact_critical_value_lies_in_kfios_certified_bracket_of_the_dual_problem():
    # the control MARE on (A, B, W, U) is the estimation MARE of (A', B', W, U): kfio bounds brackets its critical value
    import kfio

    dual = kfio.System(A=[["5/4", "0"], ["1", "11/10"]], C=[["0", "1"]], Q=[["1", "0"], ["0", "1"]], R=[["1"]])
    interval = kfio.bounds(dual, kfio.bernoulli("0.9")).to_dict()["critical_probability"]
    assert interval["lower"]["value"] <= 57 / 121 <= interval["upper"]["value"]
    # and above the bracket's upper end the LQG request has a fixed point and gains
    nu = Fraction(interval["upper"]["value"]).limit_denominator(10**6) + Fraction(1, 10**6)
    assert _report(_two("0.9", _text(nu)))["lqg"]["stationary_gains"]["exist"]


def test_schur_cohn_and_the_unstable_product_against_numpy():
    rng = np.random.default_rng(7)
    for _ in range(40):
        c = [Fraction(int(x), 4) for x in rng.integers(-9, 10, size=4)] + [Fraction(1)]
        roots = np.roots([float(x) for x in reversed(c)])
        inside = np.abs(roots).max() < 1 - 1e-9
        outside_or_on = np.abs(roots).max() > 1 + 1e-9
        if inside or outside_or_on:
            assert schur_stable(c) == bool(inside)
    A = [[Fraction(3), Fraction(1)], [Fraction(0), Fraction(1, 2)]]
    assert unstable_modulus_product(tuple(map(tuple, A)))[0] == 9
    # x^2 - 3x - 1 has one root on each side of the circle: nu_c = 1 - 1/x^2, x = (3 + sqrt(13))/2, quadratic
    crit = known_critical(((Fraction(0), Fraction(1)), (Fraction(1), Fraction(3))), ((Fraction(0),), (Fraction(1),)))
    assert crit is not None and crit.exact == "(-9 + 3*sqrt(13))/2"
    assert crit.value == pytest.approx(1 - 1 / ((3 + np.sqrt(13)) / 2) ** 2, rel=1e-14)


# --- the doors -----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    settings = Settings(workers=1, job_workers=1, time_budget_s=60)
    with ready_client(settings) as c:
        yield c


@pytest.mark.slow  # starts the service's worker pools
def test_below_the_critical_value_is_exit_1_and_http_200(client, tmp_path, capsys):
    body = _scalar("1.2", "0.3", "0.9")
    path = tmp_path / "below.json"
    path.write_text(json.dumps(body))
    assert cli_main(["loop", str(path)]) == 1
    text = capsys.readouterr().out
    assert text.startswith("verdict: UNSTABLE") and "11/36" in text and "Rohr, Marelli and Fu 2014" in text
    assert cli_main(["loop", "--json", str(path)]) == 1
    cli = json.loads(capsys.readouterr().out)
    r = client.post("/v1/loop", json=body)
    assert r.status_code == 200
    http = r.json()
    assert http["verdict"] == cli["verdict"] == "unstable" and http["cost"] is None
    assert http["lqg"] == cli["lqg"]
    # there is no loop to draw: the plot names the rule instead of failing
    plot = client.post("/v1/plots/loop-region?points=3", json=body)
    assert plot.status_code == 422 and "no stationary LQG gains" in plot.text
    just_above = _scalar("1.2", _text(Fraction(11, 36) + Fraction(1, 1000)), "0.9")
    path.write_text(json.dumps(just_above))
    assert cli_main(["loop", str(path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert any(line.startswith("  sensor:   optimal > 0.305556 = 11/36 | stationary ") for line in lines), lines
