"""``analyze(..., tail="kappa")``: the tail exponent alone, the same float as the whole tail report.

A sweep row prints ``kappa`` and nothing else of the tail (Mo and Sinopoli,
2012), so the sweep asks :func:`kfio.stability.analyze` for it alone
(:func:`kfio.design.tail_kappa`).  Each case here compares it, bit for bit,
with ``TailReport.kappa`` of the full analysis: real, complex, degenerate
and unit-modulus modes, stable plants, several sensors, Bernoulli,
Gilbert-Elliott and order-2 Markov channels; and the rest of the report is
unchanged.
"""

from __future__ import annotations

import json
import math

import pytest

from kfio import load_request
from kfio.stability import analyze

BERN = {"model": "bernoulli", "arrival_probability": "3/10"}
GE = {"model": "gilbert_elliott", "failure_rate": "2/5", "recovery_rate": "7/10"}
MARKOV = {"model": "markov", "order": 2, "arrival_probability": {"00": "1/5", "01": "1/2", "10": "3/5", "11": "9/10"}}

PLANTS = [
    ({"A": [[2]], "C": [[1]]}, "a scalar mode"),
    ({"A": [["1.25", 0], [1, "1.1"]], "C": [[1, 1]]}, "two real modes (the bench's plant)"),
    ({"A": [[2, 0], [0, -2]], "C": [[1, 1]]}, "a degenerate pair"),
    ({"A": [[0, -2], [2, 0]], "C": [[1, 0]]}, "a complex pair"),
    ({"A": [[1, 0], [0, 2]], "C": [[1, 1]]}, "a unit-modulus mode beside an unstable one"),
    ({"A": [[1]], "C": [[1]]}, "a unit-modulus mode alone (no tail)"),
    ({"A": [["1/2"]], "C": [[1]]}, "a stable mode (no tail)"),
    ({"A": [["1.5", 1], [0, "-1.2"]], "C": [[1, 0]]}, "two modes, one packet"),
]


def _same(tree: dict) -> None:
    req = load_request(json.dumps(tree))
    full, light = analyze(req), analyze(req, tail="kappa")
    assert full.tail is not None and light.tail is not None
    k_full, k_light = full.tail.kappa, light.tail.kappa
    if k_full is None:
        assert k_light is None
    else:
        assert isinstance(k_light, float) and math.isfinite(k_light)
        assert k_light.hex() == k_full.hex(), tree  # the same float, bit for bit (also the sign of 0)
    assert light.tail.moments == {} and "not computed" in light.tail.statement
    drop = lambda d: {k: v for k, v in d.items() if k != "tail"}  # noqa: E731
    assert drop(light.to_dict()) == drop(full.to_dict())


@pytest.mark.parametrize(("system", "what"), PLANTS, ids=[w for _, w in PLANTS])
@pytest.mark.parametrize("channel", [BERN, GE, MARKOV], ids=["bernoulli", "gilbert_elliott", "markov2"])
def test_kappa_alone_equals_the_tail_report(system, what, channel):
    _same({"system": system, "channel": channel})


def test_kappa_alone_several_sensors():
    """Two Bernoulli sensors (the Pareto front's argmax) and a Bernoulli beside a Gilbert-Elliott sensor."""
    system = {
        "A": [[0, 0, 2], [2, 0, 0], [0, 2, 0]],
        "C": [[1, 0, 0], [0, 1, 1]],
        "sensors": [{"name": "s0", "rows": [0]}, {"name": "s1", "rows": [1]}],
    }
    for channels in (
        {"s0": BERN, "s1": {"model": "bernoulli", "arrival_probability": "4/5"}},
        {"s0": BERN, "s1": GE},
    ):
        _same({"system": system, "channel": {"model": "per_sensor", "channels": channels}})
