"""Stationary distribution from the simulation: outage, quantiles, Hill exponent beside the exact kappa.

The exact kappa is :mod:`kfio.design._tail` (Mo and Sinopoli 2012; kfio's
extension for degenerate blocks); the independent route is the numpy Riccati
sampler of ``tests/support/tail_sim.py`` (shares nothing with kfio.simulation).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from kfio import InvalidInput, LimitExceeded, load_request, simulate
from kfio.simulation._stationary import hill, wilson

from support.tail_sim import stationary_traces

BERN = lambda lam: {"model": "bernoulli", "arrival_probability": lam}  # noqa: E731
GE = lambda p, q: {"model": "gilbert_elliott", "failure_rate": p, "recovery_rate": q}  # noqa: E731


def sim(A, C, channel, **opts):
    n = len(A)
    eye = [[1 if i == j else 0 for j in range(n)] for i in range(n)]
    body = {
        "system": {"A": A, "C": C, "Q": eye, "R": [[1]]},
        "channel": channel,
        "options": {"simulate": {"steps": 80, "trajectories": 12000, "seed": 0, **opts}},
    }
    return simulate(load_request(json.dumps(body)))


def test_wilson_and_hill_on_known_inputs():
    lo, hi = wilson(50, 100)
    assert lo == pytest.approx(0.4038, abs=1e-4) and hi == pytest.approx(0.5962, abs=1e-4)
    # Pareto with exponent 1.5: P(X > x) = x^-1.5 for x >= 1; Hill is unbiased there
    x = (1 - np.random.default_rng(0).random(40000)) ** (-1 / 1.5)
    assert hill(x)[0] == pytest.approx(1.5, rel=0.05)


# Tolerance 0.06 on kappa <= 0.6 and 6 % on 1.55: measured bias of the Hill estimate with k = M/20 on these
# lattice-like tails was <= 0.05 over two seeds (see kfio.simulation._stationary); the wrong formula for
# the degenerate cases (the non-degenerate kappa, 1.0 and 0.5) is excluded by it.
@pytest.mark.parametrize(
    "A, C, channel, tol",
    [
        ([[2]], [[1]], BERN("1/2"), 0.06),
        ([[2]], [[1]], GE("1/5", "1/2"), 0.06),
        ([[2, 0], [0, -2]], [[1, 1]], BERN("3/4"), 0.06),
        ([[2, 0], [0, -2]], [[1, 1]], GE("1/4", "1/2"), 0.06),
        ([[-1.25]], [[1]], BERN("1/2"), 0.06 * 1.55),
    ],
)
def test_hill_beside_exact_kappa(A, C, channel, tol):
    st = sim(A, C, channel).stationary
    assert st.hill == pytest.approx(st.kappa, abs=tol)


def test_outage_against_independent_sampler():
    st = sim([[2, 0], [0, -2]], [[1, 1]], BERN("3/4"), outage_thresholds=[100, "1000"]).stationary
    other = stationary_traces(
        [[2, 0], [0, -2]], [[1, 1]], p_loss_after_arrival=0.25, q_recover=0.75, steps=80, keep=1, chains=12000, seed=5
    )
    for m, p, lo, hi in st.outage:
        q = float((other > m).mean())
        half = 1.96 * np.sqrt(q * (1 - q) / other.size)
        assert lo - half <= q <= hi + half, (m, p, q)
    assert [m for m, *_ in st.outage] == [100.0, 1000.0]


def test_warning_where_kappa_at_most_two():
    # A = -1.25, lambda = 0.3 (critical 0.36): exact E[P_t] grows 1.094 per step
    r = sim([[-1.25]], [[1]], BERN("0.3"), steps=60, trajectories=2000)
    st = r.stationary
    assert st.mean_unreliable and st.growth_rate == pytest.approx(1.5625 * 0.7)
    assert "sample mean" in st.warnings[0] and "1.094" in st.warnings[0]
    first, second = r.summary().splitlines()[:2]
    assert first.startswith(
        "UNSTABLE (exact, Rohr, Marelli and Fu 2014, Theorem 1). Monte Carlo: sample mean unreliable"
    )
    assert second.startswith("warning: exact tail exponent kappa")
    d = r.to_dict()["stationary"]
    assert d["mean_unreliable"] is True and d["verdict"] == "unstable" and len(d["quantiles"]) == 4


def test_no_warning_with_light_tail():
    # A = 1.1, lambda = 0.9: kappa = log 10 / (2 log 1.1) = 12.1
    st = sim([["1.1"]], [[1]], BERN("0.9"), steps=40, trajectories=2000).stationary
    assert st.kappa > 12 and not st.mean_unreliable and st.warnings == ()
    q50, lo, hi = st.quantiles[0][1:]
    assert lo <= q50 <= hi


@pytest.mark.parametrize(
    "value, exc, match",
    [
        ([], InvalidInput, "non-empty list"),
        (["-1"], InvalidInput, "positive"),
        (list(range(1, 30)), LimitExceeded, "at most 20"),
    ],
)
def test_threshold_validation(value, exc, match):
    with pytest.raises(exc, match=match) as e:
        sim([[2]], [[1]], BERN("1/2"), steps=5, trajectories=10, outage_thresholds=value)
    assert e.value.field.startswith("/options/simulate/outage_thresholds")
