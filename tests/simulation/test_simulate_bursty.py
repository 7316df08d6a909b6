"""Bursty versus i.i.d. losses at the same average arrival rate (docs/simulation.md).

Scalar plant a = 1.5, C = Q = R = 1.  Bernoulli lambda = 0.75 and Gilbert-Elliott with failure
rate p = 0.1 and recovery rate q = 0.3 deliver the same long-run fraction of packets,
q / (p + q) = 0.75.  Rohr, Marelli and Fu (2014), Corollary 1: Bernoulli is stable iff a^2 (1 - lambda) < 1
(here 0.5625), Gilbert-Elliott iff a^2 (1 - q) < 1 (here 1.575): the bursty channel is unstable.
"""

from __future__ import annotations

import json
import math

import pytest

from kfio import load_request
from kfio.model._types import Request
from kfio.simulation._finite_horizon import expected_covariance
from kfio.simulation._simulate import simulate

SYSTEM = {"A": [[1.5]], "C": [[1]], "Q": [[1]], "R": [[1]]}
IID = {"model": "bernoulli", "arrival_probability": 0.75}
BURSTY = {"model": "gilbert_elliott", "failure_rate": 0.1, "recovery_rate": 0.3}


def make(channel: dict, options: dict | None = None) -> Request:
    body: dict = {"system": SYSTEM, "channel": channel}
    if options:
        body["options"] = {"simulate": options}
    return load_request(json.dumps(body))


def test_same_average_arrival_rate() -> None:
    assert make(IID).channel.mean_arrival_rate() == pytest.approx(0.75, abs=1e-12)
    assert make(BURSTY).channel.mean_arrival_rate() == pytest.approx(0.75, abs=1e-12)


def test_closed_forms_disagree_on_stability() -> None:
    a2 = 1.5**2
    assert a2 * (1 - 0.75) == pytest.approx(0.5625) and a2 * (1 - 0.75) < 1  # eq. (21): bounded
    assert a2 * (1 - 0.3) == pytest.approx(1.575) and a2 * (1 - 0.3) > 1  # eq. (24): unbounded


def test_exact_mean_levels_off_for_iid_and_grows_for_bursty() -> None:
    iid = expected_covariance(make(IID), 20)
    bursty = expected_covariance(make(BURSTY), 20)
    assert iid.growth_per_step(6) < 1.001
    assert abs(math.log(bursty.growth_per_step(6)) - math.log(1.575)) < 0.01
    assert bursty.mean_trace[-1] > 1000 * iid.mean_trace[-1]


def test_verdicts() -> None:
    from kfio import analyze

    iid, bursty = analyze(make(IID)), analyze(make(BURSTY))
    assert iid.verdict == "stable" and bursty.verdict == "unstable"
    assert max(b.rate for b in bursty.blocks if b.rate is not None) == pytest.approx(1.575)


def test_monte_carlo_same_median_much_fatter_tail() -> None:
    """Typical errors are alike; the 99th percentile is two orders of magnitude apart at t = 200."""
    opts = {"steps": 200, "trajectories": 5000, "seed": 1}
    iid, bursty = simulate(make(IID, opts)), simulate(make(BURSTY, opts))
    assert bursty.percentile(50)[-1] == pytest.approx(iid.percentile(50)[-1], rel=0.1)
    assert bursty.percentile(99)[-1] > 100 * iid.percentile(99)[-1]
