"""The Python API and the JSON route build the same request and give the same report.

Each case writes one system in several Python forms (numpy arrays of several
dtypes, tuples, Fractions, exact strings, a python-control StateSpace) and
checks that ``kfio.analyze(System(...), channel).to_dict()`` equals the
report of the JSON route (``load_request`` of the request text, then the
request-level function).  Matrices whose float32 and float64 texts agree are
chosen so that every dtype denotes the same rationals.
"""

from __future__ import annotations

import json
from decimal import Decimal
from fractions import Fraction

import control
import numpy as np
import pytest

import kfio
from kfio import load_request
from kfio.riccati_bounds import compute_bounds
from kfio.simulation import expected_covariance, simulate

# Sinopoli et al. (2004) / Rohr, Marelli and Fu (2010) 2x2 example: lambda_c = 9/25.
A = [[1.25, 0], [1, 1.1]]
C = [[1, 1]]
Q = [[20, 0], [0, 20]]
R = [[2.5]]
JSON_SYSTEM = {"A": A, "C": C, "Q": Q, "R": R}


def json_report(fn, system: dict, channel: dict, options: dict | None = None, *args):
    body = {"system": system, "channel": channel}
    if options:
        body["options"] = options
    return fn(load_request(json.dumps(body)), *args).to_dict()


FORMS = {
    "lists": dict(A=A, C=C, Q=Q, R=R),
    "float64": dict(A=np.array(A), C=np.array(C, dtype=float), Q=20 * np.eye(2), R=np.array([[2.5]])),
    "float32": dict(
        A=np.array(A, dtype=np.float32),
        C=np.array(C, dtype=np.float32),
        Q=np.array(Q, dtype=np.float32),
        R=np.array(R, dtype=np.float32),
    ),
    "int64 and float16": dict(
        A=np.array(A, dtype=np.float16),  # 1.1 as a float16 prints "1.1": its shortest text
        C=np.array(C, dtype=np.int64),
        Q=np.array(Q, dtype=np.int64),
        R=np.array(R, dtype=np.float64),
    ),
    "tuples of numpy scalars": dict(
        A=((np.float64(1.25), np.int32(0)), (np.int64(1), np.float32(1.1))),
        C=((np.uint8(1), np.int16(1)),),
        Q=((np.float64(20), 0), (0, np.float64(20))),
        R=((np.float32(2.5),),),
    ),
    "Fractions and strings": dict(
        A=[[Fraction(5, 4), Fraction(0)], [Fraction(1), Fraction(11, 10)]],
        C=[["1", "1"]],
        Q=[["20", 0], [0, "2e1"]],
        R=[[Decimal("2.5")]],
    ),
    "np.matrix": dict(A=np.matrix(A), C=np.matrix(C), Q=np.matrix(Q), R=np.matrix(R)),
}


@pytest.fixture(scope="module")
def reference():
    return json_report(kfio.analyze, JSON_SYSTEM, {"model": "bernoulli", "arrival_probability": 0.5})


@pytest.mark.parametrize("form", sorted(FORMS))
def test_every_python_form_gives_the_json_report(form, reference):
    system = kfio.System(**FORMS[form])
    assert system.A == ((Fraction(5, 4), 0), (1, Fraction(11, 10)))
    report = kfio.analyze(system, kfio.bernoulli(0.5))
    assert report.to_dict() == reference
    assert report.critical_arrival_probability_exact == "9/25" and report.verdict == "stable"


def test_a_float32_means_its_own_shortest_text_not_its_binary_value():
    # float32(0.1) is 13421773/134217728 in binary; it means 1/10, as "0.1" does in JSON
    sys = kfio.System(A=np.array([[0.1]], dtype=np.float32), C=[[1]])
    assert sys.A == ((Fraction(1, 10),),)
    # and a float64 whose shortest text has 17 digits keeps all of them
    x = 0.1 + 0.2
    assert kfio.System(A=[[x]], C=[[1]]).A[0][0] == Fraction(repr(x))


def test_statespace_discrete_gives_the_json_report(reference):
    ss = control.ss(np.array(A), np.eye(2), np.array(C), np.zeros((1, 2)), 0.1)
    system = kfio.System.from_statespace(ss, Q=Q, R=R)
    assert kfio.analyze(system, kfio.bernoulli(0.5)).to_dict() == reference
    assert kfio.System.from_statespace(control.ss(np.array(A), np.eye(2), np.array(C), 0, True)).n == 2


def test_statespace_c2d_pendulum_is_analyzed_exactly():
    # a linearized pendulum discretized by python-control: entries are 17-digit floats,
    # each read through its shortest text (the example)
    ct = control.ss([[0, 1], [9.81, -0.1]], [[0], [1]], [[1, 0]], [[0]])
    ss = control.c2d(ct, 0.01)
    system = kfio.System.from_statespace(ss, Q=np.eye(2) * 1e-3, R=[[1e-2]])
    assert system.A[0][0] == Fraction(repr(float(ss.A[0, 0])))
    body = {
        "system": {"A": ss.A.tolist(), "C": ss.C.tolist()},
        "channel": {"model": "bernoulli", "arrival_probability": 0.5},
    }
    # the JSON route writes the same floats as their repr, so both give the same verdict
    json_rep = kfio.analyze(load_request(json.dumps(body))).to_dict()
    api_rep = kfio.analyze(kfio.System(A=ss.A, C=ss.C), kfio.bernoulli(0.5)).to_dict()
    assert api_rep == json_rep and api_rep["verdict"] in ("stable", "unstable")


def test_gilbert_elliott_markov_and_per_sensor_channels_match_the_json_route():
    ge_json = {"model": "gilbert_elliott", "failure_rate": "1/10", "recovery_rate": "3/10"}
    sys = {"A": [[2, 0], [0, -2]], "C": [[1, 1]]}
    got = kfio.analyze(kfio.System(**sys), kfio.gilbert_elliott(failure_rate=0.1, recovery_rate="3/10"))
    assert got.to_dict() == json_report(kfio.analyze, sys, ge_json)

    table = {"00": 0.4, "01": 0.7, "10": 0.5, "11": 0.9}
    mk_json = {"model": "markov", "order": 2, "arrival_probability": table}
    sys2 = {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]]}
    got = kfio.analyze(kfio.System(**sys2), kfio.markov({k: np.float32(v) for k, v in table.items()}))
    assert got.to_dict() == json_report(kfio.analyze, sys2, mk_json)

    two = {
        "A": [[2.5, 0], [0, 1.5]],
        "C": [[1, 0], [0, 1]],
        "sensors": [{"name": "first", "rows": [0]}, {"name": "second", "rows": [1]}],
    }
    ps_json = {
        "model": "per_sensor",
        "channels": {
            "first": {"model": "bernoulli", "arrival_probability": 0.9},
            "second": {"model": "bernoulli", "arrival_probability": 0.6},
        },
    }
    system = kfio.System(A=two["A"], C=np.eye(2, dtype=np.int64), sensors={"first": [0], "second": (np.int64(1),)})
    # per_sensor in the other order, one value as a shorthand number: the system's order wins
    channel = kfio.per_sensor({"second": kfio.bernoulli(0.6), "first": 0.9})
    assert kfio.analyze(system, channel).to_dict() == json_report(kfio.analyze, two, ps_json)


def test_bounds_simulate_and_expected_covariance_match_the_json_route():
    sys = {"A": [[-1.25]], "C": [[1]], "Q": [[1]], "R": [[2.5]]}
    ch = {"model": "bernoulli", "arrival_probability": 0.4}
    system = kfio.System(A=np.array([[-1.25]]), C=[[1]], Q=np.eye(1), R=[[np.float32(2.5)]])
    b = kfio.bounds(system, kfio.bernoulli(0.4), options={"horizon": 3})
    assert b.to_dict() == json_report(compute_bounds, sys, ch, {"bounds": {"horizon": 3}})

    opts = {"steps": 30, "trajectories": 200, "seed": np.int64(7), "exact_steps": 4}
    s = kfio.simulate(system, kfio.bernoulli(0.4), **opts)
    assert s.to_dict() == json_report(simulate, sys, ch, {"simulate": {**opts, "seed": 7}})
    # keywords and options are the same thing; keywords win
    t = kfio.simulate(system, kfio.bernoulli(0.4), options={**opts, "seed": 99}, seed=7)
    assert t.to_dict() == s.to_dict()

    e = kfio.expected_covariance(system, kfio.bernoulli(0.4), 5, P0=[[2]])
    assert e.to_dict() == json_report(expected_covariance, sys, ch, {"simulate": {"P0": [[2]]}}, 5)


def test_request_dict_is_a_request_file_for_the_json_route():
    system = kfio.System(A=np.array([[1.1]], dtype=np.float32), C=[[1]], Q=[[1]], R=[[1]])
    body = kfio.request_dict(system, kfio.bernoulli(0.5), command="simulate", options={"steps": 3}, budget=5.5)
    assert body == {
        "system": {"A": [["11/10"]], "C": [["1"]], "Q": [["1"]], "R": [["1"]]},
        "channel": {"model": "bernoulli", "arrival_probability": "1/2"},
        "options": {"simulate": {"steps": 3}, "time_budget_s": "5.5"},
    }
    req = kfio.build_request(system, kfio.bernoulli(0.5), command="simulate", options={"steps": 3}, budget=5.5)
    assert load_request(json.dumps(body)) == req and req.time_budget_s == 5.5


def test_the_request_entry_still_works():
    req = load_request(
        json.dumps({"system": JSON_SYSTEM, "channel": {"model": "bernoulli", "arrival_probability": 0.5}})
    )
    assert kfio.analyze(req).critical_arrival_probability_exact == "9/25"
    assert kfio.analyze(req, budget=kfio.Budget(seconds=30)).verdict == "stable"
    assert kfio.expected_covariance(req, steps=2).steps == 2
