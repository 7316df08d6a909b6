"""Exact critical value of one channel parameter named by a JSON pointer (Theorem 1 on a one-parameter family).

Cross-checked against three independent routes: Rohr, Marelli and Fu (2014)'s closed form for
Bernoulli (``critical_arrival_probability``), the Gilbert-Elliott line solver
(renewal closed form, :mod:`kfio.design._ge_region`), the per-sensor
thresholds (:mod:`kfio.design._regions`), and for order-2 Markov channels
the brute-force blind-probability DP on both sides of the critical value.
"""

from __future__ import annotations

import json
from fractions import Fraction as F

import pytest

from kfio import InvalidInput, analyze, load_request
from kfio.structure._fmo import fmo_blocks

from support.bruteforce import oracle_sigma

PAIR = [["5/4", 0], [0, "-5/4"]]


def run(A, C, channel, pointer, **system):
    body = {
        "system": {"A": A, "C": C, **system},
        "channel": channel,
        "options": {"analyze": {"critical_parameter": pointer}},
    }
    return analyze(load_request(json.dumps(body)))


def test_bernoulli_matches_closed_form():
    r = run([[-1.25]], [[1]], {"model": "bernoulli", "arrival_probability": "1/2"}, "/channel/arrival_probability")
    assert r.critical_parameter.crossings[0].exact_text == r.critical_arrival_probability_exact == "9/25"
    r = run(PAIR, [[1, 1]], {"model": "bernoulli", "arrival_probability": "1/2"}, "/channel/arrival_probability")
    assert r.critical_parameter.crossings[0].exact_text == r.critical_arrival_probability_exact  # 1 - beta^-2


@pytest.mark.parametrize(
    "pointer, line", [("/channel/recovery_rate", "recovery"), ("/channel/failure_rate", "failure")]
)
def test_gilbert_elliott_matches_the_renewal_line(pointer, line):
    ge = {"model": "gilbert_elliott", "failure_rate": "1/4", "recovery_rate": "1/2"}
    r = run([["3/2", 0, 0], [0, "5/4", 0], [0, 0, "-5/4"]], [[1, 1, 1]], ge, pointer)
    mine = r.critical_parameter.crossings
    theirs = getattr(r.gilbert_elliott, line).crossings
    assert [(c.exact_text, c.left, c.right) for c in mine] == [(c.value_exact, c.left, c.right) for c in theirs]


def test_per_sensor_matches_sensor_thresholds():
    # docs/theory.md: A = diag(2.5, 1.5), one sensor per state: lambda_2 > 5/9 exactly
    body = dict(
        sensors=[{"name": "s1", "rows": [0]}, {"name": "s2", "rows": [1]}],
    )
    ch = {
        "model": "per_sensor",
        "channels": {
            "s1": {"model": "bernoulli", "arrival_probability": "9/10"},
            "s2": {"model": "bernoulli", "arrival_probability": "1/2"},
        },
    }
    r = run([["5/2", 0], [0, "3/2"]], [[1, 0], [0, 1]], ch, "/channel/channels/s2/arrival_probability", **body)
    cp = r.critical_parameter
    assert cp.crossings[0].exact_text == "5/9" and cp.basis == "extension"
    sensors = {s["sensor"]: s for s in r.regions["sensors"]}
    assert sensors["s2"]["critical_arrival_probability_exact"] == "5/9"


@pytest.mark.parametrize("key", ["00", "01", "10", "11"])
def test_markov_order_2_against_bruteforce(key):
    table = {"00": "1/2", "01": "3/5", "10": "7/10", "11": "4/5"}
    ch = {"model": "markov", "order": 2, "arrival_probability": table}
    r = run(PAIR, [[1, 1]], ch, f"/channel/arrival_probability/{key}")
    cp = r.critical_parameter
    assert r.to_dict()["critical_parameter"]["pointer"] == f"/channel/arrival_probability/{key}"
    assert len(cp.crossings) == (0 if key == "11" else 1)  # P(arrive | 11) alone cannot stabilise this pair
    for c in cp.crossings:
        for eps, side in ((-1e-4, c.left), (1e-4, c.right)):
            shifted = dict(table, **{key: str(F(c.value + eps).limit_denominator(10**9))})
            req = load_request(
                json.dumps({"system": {"A": PAIR, "C": [[1, 1]]}, "channel": {**ch, "arrival_probability": shifted}})
            )
            (blk,) = [b for b in fmo_blocks(req.system) if b.modulus_sq_float >= 1]
            rate = blk.modulus_sq_float * oracle_sigma(blk.phase, [req.channel])
            assert (rate > 1) == (side == "unstable"), (key, c.value, eps, rate)
    # the request's own verdict is the label of the interval holding its value
    v = float(F(table[key]))
    (label,) = [lab for a, b, lab in cp.intervals if a < v < b]
    assert label == r.verdict


@pytest.mark.parametrize(
    "pointer, match",
    [
        ("/system/A", "JSON pointer into channel"),
        ("/channel/recovery_rate", "names no arrival probability"),
        ("/channel/arrival_probability/2", "names no arrival probability"),
    ],
)
def test_bad_pointer(pointer, match):
    ch = {"model": "markov", "order": 1, "arrival_probability": {"0": "1/2", "1": "3/5"}}
    with pytest.raises(InvalidInput, match=match) as e:
        run(PAIR, [[1, 1]], ch, pointer)
    assert e.value.field == "/options/analyze/critical_parameter"
