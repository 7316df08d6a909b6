"""options.simulate.outage_target: smallest lambda with estimated P(trace P_T > M) <= epsilon."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest

from kfio import load_request
from kfio.errors import InvalidInput
from kfio.simulation import simulate

A, M, EPS, T = 1.3, 8.0, 0.1, 12


def _request(target, channel=None, **sim):
    return load_request(
        json.dumps(
            {
                "system": {"A": [[A]], "C": [[1]], "Q": [[1]], "R": [[1]]},
                "channel": channel or {"model": "bernoulli", "arrival_probability": 0.5},
                "options": {"simulate": {"outage_target": target, **sim}},
            }
        )
    )


def _exact_outage(lam: float) -> float:
    """P(P_T > M) by enumerating all 2^T arrival sequences of the scalar recursion (P_0 = Q = 1)."""
    seqs = np.array(list(itertools.product((0, 1), repeat=T)), dtype=bool)
    P = np.ones(len(seqs))
    for t in range(T):
        P = np.where(seqs[:, t], A * A * P / (P + 1), A * A * P) + 1
    k = seqs.sum(axis=1)
    w = lam**k * (1 - lam) ** (T - k)
    return float(w[P > M].sum())


def _exact_threshold(tol: float = 1e-6) -> float:
    lo, hi = 0.0, 1.0
    while hi - lo > tol:
        mid = (lo + hi) / 2
        lo, hi = (lo, mid) if _exact_outage(mid) <= EPS else (mid, hi)
    return hi


@pytest.fixture(scope="module")
def report():
    return simulate(_request({"threshold": M, "epsilon": EPS, "tolerance": 0.004}, steps=T, trajectories=20000, seed=5))


def test_bracket_contains_the_exact_threshold(report):
    t = report.outage_target
    exact = _exact_threshold()
    assert t.insufficient is not None and t.sufficient is not None and t.estimate is not None
    assert t.insufficient - t.tolerance <= t.estimate <= t.sufficient
    assert t.insufficient - t.tolerance <= exact <= t.sufficient + t.tolerance, (t.insufficient, exact, t.sufficient)
    # the point estimate is within a few sampling standard deviations of the exact answer
    assert abs(t.estimate - exact) < 0.03
    # the bracket is the honest width of the interval: not absurdly wide
    assert t.sufficient - t.insufficient < 0.1


def test_common_random_numbers_make_the_estimate_monotone(report):
    probes = report.outage_target.probes
    lams = [p[0] for p in probes]
    assert lams == sorted(lams) and len(lams) >= 10
    for col in (1, 2, 3):
        vals = [p[col] for p in probes]
        assert all(b <= a for a, b in zip(vals, vals[1:])), col
    # each probe's estimate agrees with the exact outage within its Wilson interval (4 binomial standard deviations)
    for lam, p, _lo, _hi in probes:
        exact = _exact_outage(lam)
        sd = max(np.sqrt(exact * (1 - exact) / 20000), 1e-4)
        assert abs(p - exact) <= 4 * sd, (lam, p, exact)


def test_report_json_and_summary(report):
    d = report.to_dict()["outage_target"]
    assert d["label"] == "estimated"
    assert d["smallest_arrival_probability_estimate"] == report.outage_target.estimate
    assert d["bracket"]["confidently_sufficient"] == report.outage_target.sufficient
    assert "outage target" in report.summary()


def test_unreachable_target_says_none():
    # P_T >= Q = 1 > M always: the outage is 1 at every lambda
    rep = simulate(_request({"threshold": 0.5, "epsilon": 0.01}, steps=5, trajectories=200, seed=1))
    t = rep.outage_target
    assert t.estimate is None and t.sufficient is None


@pytest.mark.parametrize(
    ("target", "field"),
    [
        ({"threshold": 1, "epsilon": 0}, "/options/simulate/outage_target/epsilon"),
        ({"threshold": 1, "epsilon": 1.5}, "/options/simulate/outage_target/epsilon"),
        ({"threshold": -1, "epsilon": 0.1}, "/options/simulate/outage_target/threshold"),
        ({"epsilon": 0.1}, "/options/simulate/outage_target/threshold"),
        ({"threshold": 1, "epsilon": 0.1, "bogus": 1}, "/options/simulate/outage_target/bogus"),
        ({"threshold": 1, "epsilon": 0.1, "tolerance": 0.5}, "/options/simulate/outage_target/tolerance"),
        ([1, 2], "/options/simulate/outage_target"),
    ],
)
def test_bad_targets_name_the_field(target, field):
    with pytest.raises(InvalidInput) as err:
        simulate(_request(target, steps=5, trajectories=10))
    assert err.value.field == field


def test_needs_a_bernoulli_channel():
    ge = {"model": "gilbert_elliott", "failure_rate": 0.2, "recovery_rate": 0.6}
    with pytest.raises(InvalidInput) as err:
        simulate(_request({"threshold": 1, "epsilon": 0.1}, channel=ge, steps=5, trajectories=10))
    assert err.value.field == "/options/simulate/outage_target"
