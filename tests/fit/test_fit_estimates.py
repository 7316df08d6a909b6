"""Round trips: traces simulated from known channels give back their model and parameters."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from scipy import stats

import kfio
from kfio.fit import fit, transition_counts

from support.traces import simulate_chain


def test_bernoulli_estimate_is_the_exact_share_of_arrivals() -> None:
    r = fit("0111011011", model="bernoulli")
    assert r.parameters == {"arrival_probability": "7/10"}
    assert r.channel == {"model": "bernoulli", "arrival_probability": "7/10"}
    assert r.estimates["arrival_probability"] == Fraction(7, 10)


def test_gilbert_elliott_estimates_are_transition_shares() -> None:
    # transitions of 1 1 0 0 1 1 1 0 1: 1->1 x3, 1->0 x2, 0->0 x1, 0->1 x2
    r = fit("110011101", model="gilbert_elliott")
    assert r.parameters == {"failure_rate": "2/5", "recovery_rate": "2/3"}
    assert r.counts["transitions"] == {"0->0": 1, "0->1": 2, "1->0": 2, "1->1": 3}
    # the channel object drops into a request as the same rationals
    ch = kfio.gilbert_elliott(failure_rate=r.channel["failure_rate"], recovery_rate=r.channel["recovery_rate"])
    assert ch.table == (Fraction(2, 3), Fraction(3, 5))


def test_markov_counts_follow_kfio_history_convention() -> None:
    """History key "01" means a[t-2] = 0, a[t-1] = 1 (oldest first), as in kfio.markov."""
    a = np.array([0, 1, 1, 0, 1, 0, 0, 1, 1, 1, 0, 1], dtype=np.uint8)
    counts = transition_counts(a, 2)
    brute = np.zeros((4, 2), dtype=int)
    for t in range(2, a.size):
        brute[int(f"{a[t - 2]}{a[t - 1]}", 2), a[t]] += 1
    assert (counts == brute).all()
    r = fit(a, model="markov", order=2)
    for key in ("00", "01", "10", "11"):
        n0, n1 = brute[int(key, 2)]
        assert r.parameters[f"arrival_probability/{key}"] == str(Fraction(int(n1), int(n0 + n1))).replace(" ", "")
    assert kfio.markov(r.channel["arrival_probability"]).order == 2


def test_estimates_maximize_the_likelihood() -> None:
    """No nearby table has a larger likelihood than the estimates (a brute-force check of the MLE)."""
    a = simulate_chain([0.3, 0.8], 400, 11)
    r = fit(a, model="gilbert_elliott")
    p, q = float(r.estimates["failure_rate"]), float(r.estimates["recovery_rate"])
    c = transition_counts(a, 1)

    def loglik(p: float, q: float) -> float:
        return c[0, 1] * math.log(q) + c[0, 0] * math.log(1 - q) + c[1, 0] * math.log(p) + c[1, 1] * math.log(1 - p)

    best = loglik(p, q)
    for dp in (-0.02, 0, 0.02):
        for dq in (-0.02, 0, 0.02):
            assert loglik(p + dp, q + dq) <= best + 1e-12


@pytest.mark.slow
@pytest.mark.parametrize(
    ("table", "model", "order"),
    [
        ((0.7,), "bernoulli", 0),
        ((0.3, 0.95), "gilbert_elliott", 1),
        ((0.2, 0.9, 0.5, 0.95), "markov", 2),
    ],
)
def test_bic_recovers_the_generating_model_and_intervals_cover(table, model, order) -> None:
    a = simulate_chain(table, 100_000, 1)
    r = fit(a)
    assert (r.model, r.order) == (model, order)
    chosen = [s for s in r.scores if s["chosen"]]
    assert len(chosen) == 1 and chosen[0]["bic"] == min(s["bic"] for s in r.scores if s["bic"] is not None)
    assert len(r.scores) == 5  # every candidate is reported, orders 0..4
    truth = _truth(table, order)
    for name, value in truth.items():
        lo, hi = r.intervals[name]
        assert lo <= value <= hi, (name, value, lo, hi)
        assert abs(float(r.estimates[name]) - value) < 0.02
    assert r.goodness_of_fit["fits"] is True
    assert r.warnings == ()


def _truth(table, order) -> dict[str, float]:
    if order == 0:
        return {"arrival_probability": table[0]}
    if order == 1:
        return {"failure_rate": 1 - table[1], "recovery_rate": table[0]}
    return {f"arrival_probability/{format(h, f'0{order}b')}": x for h, x in enumerate(table)}


def test_estimates_converge() -> None:
    errors = []
    for n in (1_000, 10_000, 100_000):
        r = fit(simulate_chain((0.4, 0.9), n, 5), model="gilbert_elliott")
        errors.append(abs(float(r.estimates["recovery_rate"]) - 0.4) + abs(float(r.estimates["failure_rate"]) - 0.1))
    assert errors[-1] < 0.01
    assert errors[-1] < errors[0]


def _binomial_floor(level: float, runs: int) -> float:
    """The coverage count below which a level-``level`` procedure is refuted at 0.1% (one-sided)."""
    return float(stats.binom.ppf(0.001, runs, level))


@pytest.mark.slow
def test_bernoulli_intervals_cover_at_their_nominal_rate() -> None:
    """400 traces of 60 packets: the exact 95% interval covers lambda = 0.3 in at least about 95% of them.

    Clopper-Pearson is conservative (coverage >= 95% for every lambda), so the
    count is compared with the 0.1% quantile of Binomial(400, 0.95), and the
    intervals must not be trivially wide: coverage below 100%, widths near
    the normal approximation's.
    """
    rng = np.random.default_rng(2026)
    covered = 0
    widths = []
    for _ in range(400):
        a = (rng.random(60) < 0.3).astype(np.uint8)
        if a.sum() in (0, a.size):
            continue
        r = fit(a, model="bernoulli")
        lo, hi = r.intervals["arrival_probability"]
        covered += lo <= 0.3 <= hi
        widths.append(hi - lo)
    assert covered >= _binomial_floor(0.95, 400)
    assert covered < 400
    assert np.mean(widths) < 1.3 * 2 * 1.96 * math.sqrt(0.3 * 0.7 / 60)


@pytest.mark.slow
def test_joint_box_covers_both_gilbert_elliott_parameters() -> None:
    """The Bonferroni box (each interval at 97.5%) holds (p, q) together in at least about 95% of 400 traces."""
    covered = 0
    for seed in range(400):
        r = fit(simulate_chain((0.4, 0.8), 300, seed), model="gilbert_elliott")
        (plo, phi), (qlo, qhi) = r.intervals["failure_rate"], r.intervals["recovery_rate"]
        covered += plo <= 0.2 <= phi and qlo <= 0.4 <= qhi
    assert covered >= _binomial_floor(0.95, 400)
    assert covered < 400


def test_level_changes_the_intervals_not_the_estimates() -> None:
    a = simulate_chain((0.6,), 2000, 3)
    r95, r99 = fit(a), fit(a, level="0.99")
    assert r95.parameters == r99.parameters
    (l95, h95), (l99, h99) = r95.intervals["arrival_probability"], r99.intervals["arrival_probability"]
    assert l99 < l95 and h99 > h95
    assert r99.to_dict()["level"] == 0.99


def test_hidden_state_channel_is_flagged() -> None:
    """Two Bernoulli regimes switching slowly (Elliott 1963): loss runs a mixture of two geometric laws.

    Among Bernoulli and Gilbert-Elliott (geometric loss runs) none fits, and the warning says so.
    """
    rng = np.random.default_rng(4)
    regime = np.cumsum(rng.random(100_000) < 0.001) % 2
    a = (rng.random(100_000) < np.where(regime == 0, 0.8, 0.3)).astype(np.uint8)
    r = fit(a, max_order=1)
    assert r.goodness_of_fit["fits"] is False
    assert any("no candidate model fits" in w for w in r.warnings)
    # the same law with one regime only fits
    assert fit(a[regime == 0], max_order=1).goodness_of_fit["fits"] is True


def test_joint_intervals_are_bonferroni_clopper_pearson() -> None:
    """Each of the m = 2 Gilbert-Elliott intervals is the exact beta-quantile interval at 1 - 0.05 / 2."""
    r = fit("1101100111010011101101100011101", model="gilbert_elliott")
    for name, (k, n) in r.trials.items():
        lo, hi = r.intervals[name]
        assert lo == pytest.approx(stats.beta.ppf(0.0125, k, n - k + 1), rel=1e-9)
        assert hi == pytest.approx(stats.beta.ppf(0.9875, k + 1, n - k), rel=1e-9)
        mlo, mhi = r.marginal_intervals[name]
        assert mlo == pytest.approx(stats.beta.ppf(0.025, k, n - k + 1), rel=1e-9)
        assert lo < mlo and hi > mhi
