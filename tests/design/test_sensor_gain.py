"""Which sensor's improvement lowers the worst rate most (extension); checked by re-running analyze."""

from __future__ import annotations

import json
from fractions import Fraction as F

import pytest

from kfio import analyze, load_request


def request(A, C, lams):
    sensors = [{"name": f"s{i + 1}", "rows": [i]} for i in range(len(C))]
    ch = {f"s{i + 1}": {"model": "bernoulli", "arrival_probability": str(x)} for i, x in enumerate(lams)}
    body = {"system": {"A": A, "C": C, "sensors": sensors}, "channel": {"model": "per_sensor", "channels": ch}}
    return load_request(json.dumps(body))


@pytest.mark.parametrize(
    "A, C, lams",
    [
        ([["5/2", 0], [0, "3/2"]], [[1, 0], [0, 1]], [F(9, 10), F(1, 2)]),
        ([["5/4", 0], [1, "11/10"]], [[1, 0], [1, 1]], [F(1, 4), F(1, 4)]),
        ([["5/4", 0], [0, "-5/4"]], [[1, 1], [1, 0]], [F(3, 5), F(1, 5)]),
    ],
)
def test_halving_effect_matches_a_rerun(A, C, lams):
    g = analyze(request(A, C, lams)).regions["sensor_improvement"]
    worst = max(b.rate for b in analyze(request(A, C, lams)).blocks if b.rate is not None)
    assert g["worst_rate"] == pytest.approx(worst, rel=1e-12)
    for i, s in enumerate(g["sensors"]):
        better = list(lams)
        better[i] = 1 - (1 - lams[i]) / 2
        rerun = max(b.rate for b in analyze(request(A, C, better)).blocks if b.rate is not None)
        assert s["worst_rate_if_loss_halved"] == pytest.approx(rerun, rel=1e-9)
        # the binding pattern alone drops by exactly 0.5^elasticity; the others can only keep the max higher
        assert rerun >= worst * 0.5 ** s["elasticity"] * (1 - 1e-9)
    best = min(g["sensors"], key=lambda s: s["worst_rate_if_loss_halved"])
    assert g["best"] in (best["sensor"], None)
