"""Exact Gilbert-Elliott stability region (Theorem 1 of Rohr, Marelli and Fu 2014 on the (p, q) family).

Checks: the closed forms of docs/theory.md (non-degenerate line
``beta (1 - q) = 1``, You, Fu and Xie 2011; ``beta^2 ((1 - q)^2 + p q) = 1``
for ``alpha diag(1, -1)``), the renewal product against the exact transfer
matrices, exact labels against the independent brute-force DP of
``tests/support/bruteforce.py`` at random points on both sides and right next to
the curve, and the exact finite-horizon growth of ``E[P_t]``.
"""

from __future__ import annotations

import json
import math
import random
import zlib
from fractions import Fraction as F

import mpmath
import numpy as np
import pytest
import sympy

from kfio import InvalidInput, analyze, expected_covariance, load_request
from kfio.design._ge_region import critical_on_line, ge_structure
from kfio.model._types import MarkovChannel
from kfio.sigma._sigma import compute_sigma, period_transfer_matrix
from kfio.structure._fmo import fmo_blocks

from support.bruteforce import oracle_sigma

GE = lambda p, q: {"model": "gilbert_elliott", "failure_rate": p, "recovery_rate": q}  # noqa: E731

# (A, C): non-degenerate scalar, the degenerate pair of docs/theory.md, period 3, two blocks (envelope)
SYSTEMS = {
    "scalar": ([["3/2"]], [[1]]),
    "pair": ([["5/4", 0], [0, "-5/4"]], [[1, 1]]),
    "cycle3": ([[0, 0, "11/10"], ["11/10", 0, 0], [0, "11/10", 0]], [[1, 0, 0]]),
    "cycle6": (
        [[("11/10" if (i - j) % 6 == 1 else 0) for j in range(6)] for i in range(6)],
        [[1, 0, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0]],
    ),
    "two_blocks": ([["3/2", 0, 0], [0, "5/4", 0], [0, 0, "-5/4"]], [[1, 1, 1]]),
}


def request(name, p, q, **options):
    A, C = SYSTEMS[name]
    body = {"system": {"A": A, "C": C}, "channel": GE(str(p), str(q))}
    if options:
        body["options"] = {"analyze": options}
    return load_request(json.dumps(body))


def test_non_degenerate_vertical_line():
    # You, Fu, Xie (2011): |alpha|^2 (1 - q) < 1, whatever p: q* = 1 - 4/9 = 5/9
    g = analyze(request("scalar", "3/10", "1/2")).gilbert_elliott
    assert g.recovery.critical.value_exact == "5/9" and g.recovery.critical.left == "unstable"
    assert g.failure.crossings == () and g.failure.status() == "unstable for every failure rate"
    assert g.patterns[0].equation() == "(9/4)**1 * (1 - q) = 1"


def test_degenerate_pair_closed_form():
    # beta^2 ((1 - q)^2 + p q) = 1 with beta = 25/16 (docs/theory.md)
    r = analyze(request("pair", "1/4", "1/2"))
    g = r.gilbert_elliott
    expected = sympy.Rational(625, 256) * ((1 - sympy.Symbol("q")) ** 2 + sympy.Symbol("p") * sympy.Symbol("q")) - 1
    assert sympy.expand(g.patterns[0].boundary_poly() - expected) == 0
    # p*(1/2) solves (625/256)(1/4 + p/2) = 1 exactly: p = 2 (256/625 - 1/4) = 399/1250
    assert g.failure.critical.value_exact == "399/1250" and g.failure.critical.left == "stable"
    q_star = sympy.sympify(g.recovery.critical.value_exact)  # our own output, not user text
    assert sympy.simplify(sympy.Rational(625, 256) * ((1 - q_star) ** 2 + q_star / 4) - 1) == 0
    assert r.to_dict()["gilbert_elliott_region"]["critical_recovery_rate"]["status"] == "threshold"
    assert "critical recovery rate q at p = 1/4: 0.456401" in r.summary()


@pytest.mark.parametrize("name", ["pair", "cycle3", "cycle6"])
def test_renewal_product_matches_transfer_matrix(name):
    # rho(P_F) = prod_m u_{a_m+1}(p, q) against the exact one-period matrix (rank one: rho = trace)
    req = request(name, "1/3", "2/5")
    blocks = fmo_blocks(req.system)
    items = [(b, compute_sigma(b.phase, [req.channel]) if b.modulus_sq_float >= 1 else None) for b in blocks]
    rng = random.Random(7)
    for pt in ge_structure(items).patterns:
        for _ in range(5):
            p, q = F(rng.randint(1, 99), 100), F(rng.randint(1, 99), 100)
            ch = MarkovChannel("gilbert_elliott", 1, (q, 1 - p))
            P = period_transfer_matrix(pt.period, frozenset((n, 0) for n in pt.allowed), [ch])
            assert pt.rho(p, q) == sum(P[i][i] for i in range(len(P)))


def _oracle_rate(req):
    rates = []
    for b in fmo_blocks(req.system):
        if b.modulus_sq_float >= 1:
            rates.append(b.modulus_sq_float * oracle_sigma(b.phase, [req.channel]))
    return max(rates)


@pytest.mark.parametrize("name", ["pair", "cycle3", pytest.param("cycle6", marks=pytest.mark.slow), "two_blocks"])
def test_labels_against_bruteforce_dp(name):
    rng = random.Random(zlib.crc32(name.encode()))
    seen = set()
    for k in range(8 if name.startswith("cycle") else 16):
        # half the points in the corner of small failure and large recovery rates, where the stable region is
        p, q = (
            (F(rng.randint(1, 49), 50), F(rng.randint(1, 49), 50))
            if k % 2
            else (F(rng.randint(1, 12), 50), F(rng.randint(30, 49), 50))
        )
        req = request(name, p, q)
        label, _ = ge_structure(_items(req)).label(p, q)
        rate = _oracle_rate(req)
        if abs(rate - 1) < 1e-6:
            continue
        assert label == ("unstable" if rate > 1 else "stable"), (p, q, rate)
        assert analyze(req).verdict == label
        seen.add(label)
    assert seen == {"stable", "unstable"} or name.startswith("cycle")  # cycles: both sides in the next test


def _items(req):
    blocks = fmo_blocks(req.system)
    return [(b, compute_sigma(b.phase, [req.channel]) if b.modulus_sq_float >= 1 else None) for b in blocks]


@pytest.mark.parametrize("name, p", [("pair", F(1, 4)), ("cycle3", F(1, 20)), ("two_blocks", F(1, 5))])
def test_critical_recovery_rate_against_dp_next_to_the_curve(name, p):
    req = request(name, p, "1/2")
    line = critical_on_line(ge_structure(_items(req)), "q", p)
    crit = line.critical
    assert crit is not None
    with mpmath.workdps(30):
        for eps, side in ((F(1, 10**5), crit.right), (-F(1, 10**5), crit.left)):
            q = F(mpmath.nstr(mpmath.mpf(crit.value) + eps, 20))
            rate = _oracle_rate(request(name, p, q))
            assert (rate > 1) == (side == "unstable"), (q, rate)
            assert abs(rate - 1) < 1e-3  # the DP sees the curve right there


def test_envelope_of_two_blocks():
    # stable iff q > 5/9 (block 3/2) and (625/256)((1-q)^2 + p q) < 1 (block +-5/4)
    r = analyze(request("two_blocks", "2/5", "3/5", ge_grid=9))
    g = r.gilbert_elliott
    m = g.map
    for i in range(len(m.rates)):
        for j in range(len(m.rates)):
            pf, qf = F(2 * i + 1, 18), F(2 * j + 1, 18)
            want = qf > F(5, 9) and F(625, 256) * ((1 - qf) ** 2 + pf * qf) < 1
            assert (m.labels[i][j] == "stable") == want
    equations = {pc["equation"] for pc in m.pieces}
    assert equations == {"(9/4)**1 * (1 - q) = 1", "(25/16)**2 * (p*q + q**2 - 2*q + 1) = 1"}
    # at p = 2/5 the degenerate block decides: q^2 - (2 - p) q + 1 - 256/625 = 0, smaller root 0.577 > 5/9
    crit = g.recovery.critical
    assert crit.pattern.period == 2 and crit.left == "unstable"
    assert crit.value == pytest.approx(0.8 - math.sqrt(0.8**2 - (1 - 256 / 625)), rel=1e-12)
    # at q = 3/5 the failure rate decides through the same block: p < (256/625 - 4/25) / (3/5)
    assert g.failure.critical.value_exact == "52/125"  # (256/625 - 4/25) / (3/5)
    d = r.to_dict()["gilbert_elliott_region"]["map"]
    assert len(d["labels"]) == 9 and d["pieces"][0]["points"] > 0


def test_recovery_is_not_monotone():
    # p = 21/50: (1 - q)^2 + p q < 256/625 only between two roots: more recovery can destabilise
    line = analyze(request("pair", "21/50", "7/10")).gilbert_elliott.recovery
    assert line.status() == "several"
    assert [iv[2] for iv in line.intervals] == ["unstable", "stable", "unstable"]
    lo, hi = line.crossings
    assert lo.value + hi.value == pytest.approx(2 - 0.42, rel=1e-12)  # the two roots of one quadratic


@pytest.mark.parametrize("side, q", [("unstable", "7/20"), ("stable", "3/5")])
def test_exact_finite_horizon_growth(side, q):
    # Exact E[P_t] (enumeration of 2^18 sequences) on both sides of q*(1/4) = 0.456: on the unstable side it
    # grows like the rate (measured 2.3 % off at t = 18); on the stable side it converges and its increments
    # shrink by about the rate per step (measured 3 % off).  Tolerances 5 % and 10 %.
    A, C = SYSTEMS["pair"]
    body = {"system": {"A": A, "C": C, "Q": [[1, 0], [0, 1]], "R": [[1]]}, "channel": GE("1/4", q)}
    req = load_request(json.dumps(body))
    rate = analyze(req).blocks[0].rate
    fh = expected_covariance(req, 18)
    if side == "unstable":
        assert rate > 1.05 and fh.growth_per_step(window=6) == pytest.approx(rate, rel=0.05)
    else:
        d = np.diff(fh.mean_trace[-8:])
        assert rate < 0.95 and (d > 0).all()
        assert float(np.mean(d[1:] / d[:-1])) == pytest.approx(rate, rel=0.1)


def test_options_validation():
    with pytest.raises(InvalidInput, match="ge_grid must be an integer"):
        analyze(request("pair", "1/4", "1/2", ge_grid=1))
    with pytest.raises(InvalidInput, match="/options/analyze/ge_grid"):
        analyze(request("pair", "1/4", "1/2", ge_grid=True))
    with pytest.raises(InvalidInput, match="unknown option"):
        analyze(request("pair", "1/4", "1/2", grid=3))
    bern = load_request(
        json.dumps(
            {
                "system": {"A": [[2]], "C": [[1]]},
                "channel": {"model": "bernoulli", "arrival_probability": 0.5},
                "options": {"analyze": {"ge_grid": 5}},
            }
        )
    )
    with pytest.raises(InvalidInput, match="needs a single gilbert_elliott channel"):
        analyze(bern)


@pytest.mark.parametrize(
    "knob, value, why", [("GE_AUTO_MAX_PERIOD", 1, "period 2 > 1"), ("GE_AUTO_MAX_STEPS", 0, "steps")]
)
def test_unasked_region_never_costs_much(monkeypatch, knob, value, why):
    # unasked, the region is skipped (with a warning) beyond a period or a search budget; the verdict stands
    import kfio.stability._verdict as verdict_module

    monkeypatch.setattr(verdict_module, knob, value)
    r = analyze(request("pair", "1/4", "1/2"))
    assert r.gilbert_elliott is None and r.verdict == "stable"
    assert any("Gilbert-Elliott critical rates not computed" in w and why in w for w in r.warnings)
    # asked for, it is computed under the request's budget
    assert analyze(request("pair", "1/4", "1/2", ge_grid=3)).gilbert_elliott is not None
