"""Bounds on the optimal UDP-like critical region (kfio.loop._udp_bounds), checked by brute force over fixed designs.

The outer bound says no design at all has a finite cost below the optimal filter's critical
sensor probability or below 1 - 1/rho(A)^2 on the actuator link; a grid of fixed gains, both
estimator forms and both protocols, decided exactly just outside the bound, must never be stable,
and some of them must be stable inside it (the bound is not vacuous).
"""

from __future__ import annotations

import itertools
import json
from fractions import Fraction as F
from pathlib import Path

from kfio.loop import analyze_loop, parse_loop_request
from kfio.loop._mjls import loop_mjls
from kfio.loop._region import _bernoulli
from kfio.loop._verdict import decide

ROOT = Path(__file__).resolve().parents[2]


def _body(protocol: str, on_loss: str = "zero") -> dict:
    body = json.loads((ROOT / "examples" / "loop_scalar.json").read_text())
    body["options"]["loop"].update(protocol=protocol, on_loss=on_loss)
    return body


def test_udp_report_gives_the_outer_bound_in_closed_form_and_the_inner_bound_at_the_request():
    out = analyze_loop(parse_loop_request(_body("udp"))).to_dict()["udp_region_bounds"]
    outer = out["outer"]
    # a = 5/4: the optimal filter needs gamma > 1 - 1/a^2 = 9/25 (c != 0, scalar); the actuator nu > 9/25
    assert outer["sensor_arrival_probability_above_exact"] == "9/25"
    assert outer["actuator_arrival_probability_above_exact"] == "9/25"
    assert out["request_point_inside_optimal_region"] is True  # the given gains are stable there
    held = analyze_loop(parse_loop_request(_body("udp", "hold"))).to_dict()["udp_region_bounds"]["outer"]
    assert held["actuator_arrival_probability_above"] is None and "hold" in held["actuator_from"]
    assert analyze_loop(parse_loop_request(_body("tcp"))).to_dict()["udp_region_bounds"] is None


def test_no_fixed_design_is_stable_outside_the_outer_bound():
    base = parse_loop_request(_body("udp"))
    eps = F(1, 1000)
    outside = [(F(9, 25) - eps, F(99, 100)), (F(99, 100), F(9, 25) - eps)]
    inside = [(F(99, 100), F(99, 100))]
    stable_inside = 0
    import dataclasses

    for k, el, form, protocol in itertools.product(
        (F(1, 4), F(1, 2), F(1), F(5, 4)), (F(1, 4), F(3, 5), F(1), F(5, 4)), ("predictor", "filter"), ("udp", "tcp")
    ):
        req = dataclasses.replace(base, estimator=((k,),), feedback=((el,),), form=form, protocol=protocol)
        for lam, nu in outside:
            sys = loop_mjls(req, {"/channel": _bernoulli(lam), "/actuator_channel": _bernoulli(nu)})
            assert decide(sys).verdict != "stable", (k, el, form, protocol, lam, nu)
        for lam, nu in inside:
            sys = loop_mjls(req, {"/channel": _bernoulli(lam), "/actuator_channel": _bernoulli(nu)})
            stable_inside += decide(sys).verdict == "stable"
    assert stable_inside > 0
