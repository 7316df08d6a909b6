"""Verdicts at a stated confidence against hand-computed cases.

``A = 5/4, C = 1``: Theorem 1 of Rohr, Marelli and Fu (2014) gives
``lambda_c = 1 - 1 / (5/4)^2 = 9/25`` for Bernoulli arrivals, and for a
Gilbert-Elliott channel (non-degenerate scalar block, ``sigma = 1 - q``) the
stable set ``q > 9/25`` whatever ``p``.  The exact Clopper-Pearson ends are
recomputed here from the beta quantiles, independently of kfio.
"""

from __future__ import annotations

import dataclasses
import math
from fractions import Fraction

import numpy as np
import pytest
from scipy import stats

import kfio
from kfio.fit import analyze_at_confidence, fit, load_trace_loop_request, loop_at_confidence, with_trace
from kfio.loop import analyze_loop
from kfio.stability import analyze

from support.traces import simulate_chain

PLANT = kfio.load_request(
    '{"system": {"A": [["5/4"]], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": 0.5}}'
)
LAMBDA_C = 9 / 25


def _exact_trace(ones: int, n: int, seed: int = 0) -> np.ndarray:
    a = np.zeros(n, dtype=np.uint8)
    a[:ones] = 1
    np.random.default_rng(seed).shuffle(a)
    return a


def _verdict(a: np.ndarray, level=None):
    request, found = with_trace(PLANT, a, level)
    point = analyze(request).verdict
    return point, analyze_at_confidence(request, found, point)


def _cp(k: int, n: int, level: float) -> tuple[float, float]:
    alpha = 1 - level
    return stats.beta.ppf(alpha / 2, k, n - k + 1), stats.beta.ppf(1 - alpha / 2, k + 1, n - k)


def test_long_trace_well_above_the_critical_value_is_stable() -> None:
    a = _exact_trace(12_000, 20_000)
    point, v = _verdict(a)
    assert point == "stable" and v.verdict == "stable" and v.samples_needed is None
    lo, hi = v.intervals["arrival_probability"]
    assert lo == pytest.approx(_cp(12_000, 20_000, 0.95)[0], rel=1e-9) and lo > LAMBDA_C
    assert v.corners["worst"]["verdict"] == "stable"
    assert Fraction(v.corners["worst"]["channel"]["arrival_probability"]) <= Fraction(lo)  # rounded outward


def test_trace_far_below_is_unstable() -> None:
    point, v = _verdict(_exact_trace(400, 2_000))
    assert point == "unstable" and v.verdict == "unstable" and v.samples_needed is None
    assert _cp(400, 2_000, 0.95)[1] < LAMBDA_C


def test_short_trace_near_the_critical_value_is_undecided_with_samples_needed() -> None:
    """lambda_hat = 37/100 from 1000 packets: the interval holds 9/25 (0.34 .. 0.40)."""
    point, v = _verdict(_exact_trace(370, 1_000))
    assert point == "stable" and v.verdict == "undecided"
    lo, _ = v.intervals["arrival_probability"]
    closed = 1_000 * ((0.37 - lo) / (0.37 - LAMBDA_C)) ** 2  # N (half-width / distance)^2
    assert v.samples_needed == pytest.approx(closed, rel=1e-3)
    # a trace of that length (same estimate) decides, one well short of it does not
    longer = math.ceil(v.samples_needed * 1.1 / 100) * 100
    shorter = math.floor(v.samples_needed * 0.8 / 100) * 100
    assert _verdict(_exact_trace(longer * 37 // 100, longer))[1].verdict == "stable"
    assert _verdict(_exact_trace(shorter * 37 // 100, shorter))[1].verdict == "undecided"


def test_higher_level_widens_the_region() -> None:
    a = _exact_trace(640, 1_600)  # 0.4: lower end 0.376 at 95%, 0.369 at 99%, 0.3576 at 99.99%
    assert _verdict(a)[1].verdict == "stable"
    v = _verdict(a, "0.9999")[1]
    assert v.verdict == "undecided" and v.samples_needed is not None
    assert v.level == Fraction(9999, 10000)


def test_gilbert_elliott_region_against_the_closed_form() -> None:
    """Scalar A = 5/4, Gilbert-Elliott: stable iff q > 9/25 (sigma = 1 - q), whatever p."""
    long_stable = simulate_chain((0.5, 0.7), 30_000, 2)
    request, found = with_trace(PLANT, long_stable)
    assert found.model == "gilbert_elliott"
    v = analyze_at_confidence(request, found, analyze(request).verdict)
    qlo, _ = v.intervals["recovery_rate"]
    assert v.verdict == ("stable" if qlo > LAMBDA_C else "undecided")
    assert v.verdict == "stable"
    near = simulate_chain((0.37, 0.7), 3_000, 3)
    request, found = with_trace(PLANT, near)
    v = analyze_at_confidence(request, found, analyze(request).verdict)
    qlo, qhi = v.intervals["recovery_rate"]
    assert qlo < LAMBDA_C < qhi and v.verdict == "undecided"
    assert all(c["verdict"] for c in v.corners.values())


def test_markov_trace_verdict_uses_every_corner() -> None:
    a = simulate_chain((0.6, 0.9, 0.7, 0.95), 40_000, 4)
    request, found = with_trace(PLANT, a)
    assert (found.model, found.order) == ("markov", 2)
    point = analyze(request).verdict
    v = analyze_at_confidence(request, found, point)
    assert point == "stable" and v.verdict == "stable"
    assert "every other corner" in v.method


def test_request_channel_trace_is_fitted_and_reported() -> None:
    from kfio.fit import load_trace_request

    body = {
        "system": {"A": [["5/4"]], "C": [[1]]},
        "channel": {"model": "trace", "arrivals": "".join(map(str, _exact_trace(300, 500))), "level": "0.9"},
    }
    import json

    request, fits = load_trace_request(json.dumps(body))
    assert request.channel.table == (Fraction(3, 5),)
    assert fits["/channel"].level == Fraction(9, 10)


def test_loop_trace_against_the_loop_critical_value() -> None:
    """examples/loop_scalar.json: critical sensor arrival probability 9/16 for these gains."""
    import json
    from pathlib import Path

    tree = json.loads(Path(__file__).resolve().parents[2].joinpath("examples/loop_scalar.json").read_text())
    for ones, n, expected in ((4_000, 5_000, "stable"), (1_000, 5_000, "unstable"), (570, 1_000, "undecided")):
        tree["channel"] = {"model": "trace", "arrivals": "".join(map(str, _exact_trace(ones, n)))}
        request, fits = load_trace_loop_request(json.dumps(tree))
        report = analyze_loop(request).to_dict()
        v = loop_at_confidence(request, fits["/channel"], "/channel", report)
        assert v.verdict == expected, (ones, n)
        lo, hi = v.intervals["arrival_probability"]
        assert (lo > 9 / 16) == (expected == "stable") and (hi < 9 / 16) == (expected == "unstable")


def test_point_estimate_headline_is_unchanged() -> None:
    a = _exact_trace(370, 1_000)
    request, found = with_trace(PLANT, a)
    direct = analyze(dataclasses.replace(PLANT, channel=kfio.bernoulli("37/100")))
    assert analyze(request).to_dict() == direct.to_dict()
    assert found.channel == {"model": "bernoulli", "arrival_probability": "37/100"}
    assert fit(a).parameters == {"arrival_probability": "37/100"}
