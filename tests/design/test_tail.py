"""Tail exponent ``kappa = log(1/sigma) / (2 log|alpha|)`` (Mo and Sinopoli 2012; kfio's extension).

Three kinds of check: worked values (docs/theory.md), exact agreement with
Theorem 1 (``kappa > 1`` iff stable) and with the i.i.d. variance threshold
``lambda > 1 - 1/|a|^4`` of Rohr, Marelli and Fu (2010), and the simulated
stationary tail of an independent numpy Riccati sampler
(``tests/support/tail_sim.py``).
"""

from __future__ import annotations

import json
import random
from fractions import Fraction as F

import pytest

from kfio import analyze, load_request

from support.tail_sim import stationary_traces, survival_slope

BERN = lambda lam: {"model": "bernoulli", "arrival_probability": lam}  # noqa: E731
GE = lambda p, q: {"model": "gilbert_elliott", "failure_rate": p, "recovery_rate": q}  # noqa: E731


def run(A, C, channel):
    return analyze(load_request(json.dumps({"system": {"A": A, "C": C}, "channel": channel})))


def test_worked_scalar():
    # docs/theory.md: A = 2, Bernoulli 1/2: kappa = log 2 / log 4 = 1/2
    t = run([[2]], [[1]], BERN("1/2")).tail
    assert t.kappa_exact == "1/2" and t.kappa == pytest.approx(0.5, abs=1e-15)
    assert t.moments == {"mean": "infinite", "variance": "infinite"} and t.basis == "theorem"


def test_worked_degenerate():
    # A = diag(2, -2), C = [1 1], Bernoulli 3/4: sigma = (1/4)^(1/2) = 1/2, kappa = 1/2, an extension
    r = run([[2, 0], [0, -2]], [[1, 1]], BERN("3/4"))
    (b,) = r.tail.blocks
    assert b.sigma_exact == "1/2" and b.kappa_exact == "1/2" and b.basis == "extension"
    assert r.tail.basis == "extension" and "extension" in r.summary()


def test_degenerate_ge_closed_form():
    # sigma^2 = (1 - q)^2 + p q (docs/theory.md) = 3/8 at p = 1/4, q = 1/2
    b = run([[2, 0], [0, -2]], [[1, 1]], GE("1/4", "1/2")).tail.blocks[0]
    assert b.sigma_exact == "sqrt(6)/4"
    assert b.kappa == pytest.approx(0.5 * __import__("math").log(8 / 3) / __import__("math").log(4), rel=1e-14)


def test_report_fields_and_summary():
    r = run([[-1.25]], [[1]], BERN("1/2"))
    d = r.to_dict()["tail"]
    assert d["statement"] == "mean bounded, variance unbounded"
    assert d["kappa_exact"] == "log(2)/log(25/16)" and d["blocks"][0]["exact"] is True
    assert "tail exponent kappa = 1.55314" in r.summary()


def test_no_unstable_block():
    t = run([[0.5]], [[1]], BERN("1/2")).tail
    assert t.kappa is None and t.blocks == () and t.moments == {"mean": "finite", "variance": "finite"}


@pytest.mark.parametrize("seed", range(6))
def test_mean_finite_iff_theorem1_stable(seed):
    # kappa > 1 iff |alpha|^2 sigma < 1 for every block: the two routes must agree exactly, boundary too
    rng = random.Random(seed)
    a = F(rng.choice([5, 6, 7, 9, 11]), 4)
    cases = []
    for _ in range(4):
        lam = F(rng.randint(1, 19), 20)
        cases.append(([[str(a), 0], [0, str(-a)]], [[1, 1]], BERN(str(lam))))
        p, q = F(rng.randint(1, 9), 10), F(rng.randint(1, 9), 10)
        cases.append(([[str(a), 0], [0, str(-a)]], [[1, 1]], GE(str(p), str(q))))
        cases.append(([[str(a)]], [[1]], GE(str(p), str(q))))
    cases.append(([[str(a)]], [[1]], BERN(str(1 - 1 / a**2))))  # exactly on Theorem 1's boundary
    for A, C, ch in cases:
        r = run(A, C, ch)
        assert r.tail.moments["mean"] == {"stable": "finite", "unstable": "infinite", "boundary": "boundary"}[r.verdict]
        assert (r.tail.kappa > 1) == (r.verdict == "stable") or r.verdict == "boundary"


@pytest.mark.parametrize("a", [F(5, 4), F(3, 2), F(2)])
def test_variance_threshold_iid(a):
    # Rohr, Marelli, Fu (2010): i.i.d. losses, variance finite iff lambda > 1 - 1/a^4
    crit = 1 - 1 / a**4
    for lam, want in [(crit, "boundary"), (crit + F(1, 1000), "finite"), (crit - F(1, 1000), "infinite")]:
        t = run([[str(a)]], [[1]], BERN(str(lam))).tail
        assert t.moments["variance"] == want
        if want == "boundary":
            assert t.kappa_exact == "2"


# Simulated tails.  The survival function of a lattice-like power law oscillates
# within one factor beta^N of M, so the slope is measured between M and
# M * beta^(N j) (whole periods).  Sampling error of the slope is about 0.01
# (>= 500 effective tail samples, log-ratio 5.5); the pre-asymptotic bias of the
# prefactor reached 0.03 for the degenerate cases over seeds 0-2 at M = 100..25600.
# The tolerances 0.03 (non-degenerate) and 0.06 (degenerate) exclude the wrong
# formula in every case (non-degenerate formula on a degenerate block: 1.0 and 0.5).
@pytest.mark.slow
@pytest.mark.parametrize(
    "A, C, p, q, ratio, tol",
    [
        ([[2]], [[1]], 0.5, 0.5, 4.0**3, 0.03),  # scalar, Bernoulli 1/2: kappa = 1/2 (theorem)
        ([[2]], [[1]], 0.2, 0.5, 4.0**3, 0.03),  # scalar, Gilbert-Elliott: kappa = log 2 / log 4 (theorem)
        ([[2, 0], [0, -2]], [[1, 1]], 0.25, 0.75, 16.0**2, 0.06),  # degenerate, Bernoulli 3/4 (extension)
        ([[2, 0], [0, -2]], [[1, 1]], 0.25, 0.5, 16.0**2, 0.06),  # degenerate, Gilbert-Elliott (extension)
    ],
)
def test_exact_kappa_against_simulated_tail(A, C, p, q, ratio, tol):
    channel = BERN(str(q)) if abs(p + q - 1) < 1e-12 else GE(str(p), str(q))
    kappa = run(A, C, channel).tail.kappa
    tr = stationary_traces(A, C, p_loss_after_arrival=p, q_recover=q, steps=150, keep=50, chains=10000, seed=1)
    assert survival_slope(tr, 100.0, 100.0 * ratio) == pytest.approx(kappa, abs=tol)


def test_log_ratio_text_is_sympys_text():
    # the fast path prints what SymPy's evaluating log prints, character for character
    import sympy

    from kfio.design._tail import log_ratio_text

    rng = random.Random(11)
    pairs = [(F(2), F(2)), (F(8), F(4)), (F(25, 16), F(25, 16)), (F(10**40 + 1, 3), F(9, 8)), (F(3, 2), F(100))]
    for _ in range(200):
        q, d = rng.randint(1, 10 ** rng.randint(1, 25)), rng.randint(1, 10 ** rng.randint(1, 25))
        b = F(rng.randint(2, 10**6), rng.randint(1, 10**5))
        pairs.append((F(q + d, d), b if b > 1 else 1 / b + 1))
    for x, b in pairs:
        for N in (1, 2, 7, 60):
            expected = sympy.log(sympy.Rational(x.numerator, x.denominator)) / (
                N * sympy.log(sympy.Rational(b.numerator, b.denominator))
            )
            assert log_ratio_text(x, b, N) == str(expected), (x, b, N)
    for bad in ((F(1), F(2), 1), (F(2), F(1, 2), 1), (F(2), F(2), 0)):
        with pytest.raises(ValueError):
            log_ratio_text(*bad)


def test_log_root_ratio_text_is_sympys_text():
    # log(x) / (N log(beta)) for an algebraic beta written as CRootOf: the direct text is SymPy's
    import sympy
    from sympy import QQ, Poly

    from kfio.design._tail import log_root_ratio_text
    from kfio.structure._algebraic import AlgebraicReal
    from kfio.structure._eigen import X

    rng = random.Random(12)
    checked = 0
    while checked < 25:
        coeffs = [QQ(rng.randint(-30, 30), rng.randint(1, 9)) for _ in range(rng.randint(2, 4))]
        h = Poly([QQ(1)] + coeffs, X, domain=QQ)
        if not h.is_irreducible or h.count_roots() == 0:
            continue
        beta = AlgebraicReal(minpoly=h, index=h.count_roots() - 1)
        if beta.root_text() is None or not beta.expr().is_positive:
            continue
        x = F(rng.randint(2, 10**9), rng.randint(1, 10**6))
        x = x if x > 1 else 1 / x
        for N in (1, 2, 7):
            expected = sympy.log(sympy.Rational(x.numerator, x.denominator)) / (N * sympy.log(beta.expr()))
            assert log_root_ratio_text(x, beta, N) == str(expected), (x, h, N)
        checked += 1
    with pytest.raises(ValueError):
        log_root_ratio_text(F(1, 2), beta, 1)
