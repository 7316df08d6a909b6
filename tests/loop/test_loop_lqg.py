"""TCP-like LQG gains (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V) for a scalar plant.

The control MARE ``s = a^2 s + w - nu a^2 b^2 s^2 / (b^2 s + u)`` has a fixed point iff
``nu > 1 - 1/a^2``; the gain is ``l = a b s / (b^2 s + u)``.  The estimation MARE is its dual.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from kfio.errors import InvalidInput
from kfio.loop import analyze_loop, parse_loop_request

ROOT = Path(__file__).resolve().parents[2]


def _body(nu: str, a: str = "2") -> dict:
    return {
        "system": {"A": [[a]], "B": [[1]], "C": [[1]], "Q": [[1]], "R": [[1]]},
        "channel": {"model": "bernoulli", "arrival_probability": "0.9"},
        "actuator_channel": {"model": "bernoulli", "arrival_probability": nu},
        "controller": {"lqg": {"W": [[1]], "U": [[1]]}},
    }


def test_control_mare_fixed_point_and_gain_in_closed_form():
    req = parse_loop_request(_body("0.8"))
    a, b, w, u, nu = 2.0, 1.0, 1.0, 1.0, 0.8
    el = float(req.L[0][0])
    s = el * u / (a * b - el * b * b)  # from l = a b s / (b^2 s + u)
    assert s == pytest.approx(a * a * s + w - nu * a * a * b * b * s * s / (b * b * s + u), rel=1e-9)
    rep = analyze_loop(req)
    assert rep.verdict == "stable" and rep.request.controller == "lqg"


@pytest.mark.parametrize("nu,converges", [("0.76", True), ("0.74", False)])
def test_control_mare_converges_iff_nu_exceeds_one_minus_inverse_a_squared(nu, converges):
    # a = 2: nu_c = 1 - 1/4 = 3/4; below it the answer is a verdict without gains, not invalid input
    req = parse_loop_request(_body(nu))
    assert bool(req.L) is converges
    rep = analyze_loop(req).to_dict()
    assert rep["lqg"]["optimal"]["verdict"] == ("stable" if converges else "unstable")
    if not converges:
        assert rep["verdict"] == "unstable" and rep["cost"] is None and rep["loop"]["feedback"] is None


def test_lqg_needs_tcp_and_bernoulli_links():
    body = {**_body("0.9"), "options": {"loop": {"protocol": "udp"}}}
    with pytest.raises(InvalidInput) as err:
        parse_loop_request(body)
    assert err.value.field == "/controller/lqg"
    example = json.loads((ROOT / "examples" / "loop_scalar.json").read_text())
    assert example["controller"]["gains"]


@pytest.mark.parametrize("a,expected", [("2", "3/4"), ("-1.25", "9/25"), ("0.5", "0")])
def test_lqg_report_gives_the_scalar_critical_value_one_minus_inverse_a_squared(a, expected):
    body = _body("0.95", a)
    out = analyze_loop(parse_loop_request(body)).to_dict()["lqg"]["optimal"]
    assert out["critical_actuator_arrival_probability_exact"] == expected
    assert out["critical_actuator"]["is_exact"] is True
