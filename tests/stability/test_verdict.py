"""Rohr, Marelli and Fu (2014), Theorem 1 end to end: reference cases, structures, invariances.

Closed forms below were derived by hand for each structure and are checked
independently: sigma against the brute-force oracle of ``tests/bruteforce.py``
(dynamic programming over covered phases), and verdicts against exact
finite-horizon growth in ``tests/test_simulate_validation.py``.
"""

from __future__ import annotations

import json
import random
from fractions import Fraction as F

import pytest
import sympy
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from kfio import AssumptionViolation, analyze, load_request
from kfio.structure._fmo import fmo_blocks

from support.bruteforce import oracle_sigma

BERN = lambda lam: {"model": "bernoulli", "arrival_probability": lam}  # noqa: E731
GE = lambda p, q: {"model": "gilbert_elliott", "failure_rate": p, "recovery_rate": q}  # noqa: E731


def run(A, C, channel, **system):
    return analyze(load_request(json.dumps({"system": {"A": A, "C": C, **system}, "channel": channel})))


# --- docs/theory.md and Rohr, Marelli and Fu (2014) -------------------------------------------------


def test_scalar_seed004():
    # Sinopoli et al. (2004): A = -1.25, C = 1: lambda_c = 1 - 1/1.25^2 = 0.36
    r = run([[-1.25]], [[1]], BERN(0.5), Q=[[1]], R=[[2.5]])
    assert r.critical_arrival_probability_exact == "9/25" and r.verdict == "stable"
    assert run([[-1.25]], [[1]], BERN("0.35")).verdict == "unstable"
    assert run([[-1.25]], [[1]], BERN("9/25")).verdict == "boundary"


def test_seed004_3x3_one_unstable_eigenvalue():
    A = [[1.25, 1, 0], [0, 0.9, 7], [0, 0, 0.6]]
    r = run(A, [[1, 0, 2]], BERN(0.5), Q=[[20, 0, 0], [0, 20, 0], [0, 0, 20]], R=[[2.5]])
    assert r.critical_arrival_probability_exact == "9/25"
    assert [b.verdict for b in r.blocks] == ["stable"] * 3
    assert r.system["controllable_A_Q"] is True


def test_2x2_where_bounds_differ_theorem1_decides():
    # Sinopoli et al. (2004)'s bounds give [0.36, ~0.48]; Theorem 1: two non-degenerate blocks, lambda_c = 9/25 exactly
    r = run([[1.25, 0], [1, 1.1]], [[1, 1]], BERN("0.37"))
    assert r.critical_arrival_probability_exact == "9/25" and r.verdict == "stable"
    assert not any(b.degenerate for b in r.blocks)
    assert run([[1.25, 0], [1, 1.1]], [[1, 1]], BERN("0.35")).verdict == "unstable"


@pytest.mark.parametrize("alpha", ["3/2", "-2", "11/10"])
def test_seed001_examples_1_and_3(alpha):
    a = F(alpha)
    r = run([[alpha, 0], [0, str(-a)]], [[1, 1]], BERN("1/2"))
    (b,) = r.blocks
    assert b.degenerate and b.period == 2
    # Example 3: sigma = (1 - lambda)^(1/2), lambda_c = 1 - |alpha|^-4
    assert b.sigma == pytest.approx(0.5**0.5, rel=1e-12)
    assert F(str(sympy.nsimplify(r.critical_arrival_probability_exact))) == 1 - 1 / a**4


def test_seed001_example2_gilbert_elliott_corrected():
    # Rohr, Marelli and Fu (2014), Example 2 claims sigma^2 = max{1 - q, (1 - q)^2 + pq}. Its D_3 is wrong: after an
    # arrival at the free phase the next loss has probability p (failure rate), not 1 - q; by shift
    # invariance D_3 has the same spectral radius as D_2, so sigma^2 = (1 - q)^2 + pq for all p, q.
    for p, q in [("1/10", "3/10"), ("1/2", "9/10"), ("4/5", "1/5")]:
        r = run([[2, 0], [0, -2]], [[1, 1]], GE(p, q))
        (b,) = r.blocks
        want = ((1 - F(q)) ** 2 + F(p) * F(q)) ** 0.5
        assert b.sigma == pytest.approx(float(want), rel=1e-9)
        req = load_request(json.dumps({"system": {"A": [[2, 0], [0, -2]], "C": [[1, 1]]}, "channel": GE(p, q)}))
        block = fmo_blocks(req.system)[0]
        assert oracle_sigma(block.phase, [req.channel]) == pytest.approx(b.sigma, abs=1e-6)
    # p = 1/10, q = 3/10: the seed's formula gives sigma^2 = max(0.7, 0.52) = 0.7, the truth is 0.52.
    # With |alpha| = 1.15 the seed would say unstable (1.3225 * 0.837 = 1.107), the truth is stable.
    r = run([["1.15", 0], [0, "-1.15"]], [[1, 1]], GE("1/10", "3/10"))
    assert r.verdict == "stable" and r.blocks[0].rate == pytest.approx(1.15**2 * 0.52**0.5)


def test_boundary_is_exact():
    r = run([[1.1]], [[1]], BERN("21/121"))
    assert r.verdict == "boundary" and r.blocks[0].certified
    assert run([[1.1]], [[1]], BERN("0.17355")).verdict == "unstable"  # 21/121 = 0.1735537...
    assert run([[1.1]], [[1]], BERN("0.17356")).verdict == "stable"


def test_markov_boundary_is_exact():
    # order-2 Markov channel, non-degenerate block: sigma = P(loss | two losses) = 1 - 9/25 (Lemma 2),
    # so rate = 25/16 * 16/25 = 1 exactly; the rate comparison runs in exact arithmetic
    ch = {"model": "markov", "order": 2, "arrival_probability": {"00": "9/25", "01": "1/2", "10": "1/3", "11": "2/3"}}
    r = run([["5/4"]], [[1]], ch)
    assert r.verdict == "boundary" and r.blocks[0].certified
    ch["arrival_probability"]["00"] = "0.3601"
    assert run([["5/4"]], [[1]], ch).verdict == "stable"


def test_degenerate_markov_verdict_matches_brute_force():
    # period-2 degenerate block under an order-2 channel: sigma from the exact transfer matrix vs the DP oracle
    ch = {"model": "markov", "order": 2, "arrival_probability": {"00": "1/5", "01": "3/5", "10": "1/2", "11": "9/10"}}
    req = load_request(json.dumps({"system": {"A": [[2, 0], [0, -2]], "C": [[1, 1]]}, "channel": ch}))
    r = analyze(req)
    (b,) = r.blocks
    assert b.period == 2 and b.degenerate
    assert oracle_sigma(fmo_blocks(req.system)[0].phase, [req.channel]) == pytest.approx(b.sigma, abs=1e-6)
    assert r.verdict == ("unstable" if 4 * b.sigma > 1 else "stable")


# --- structures ---------------------------------------------------------------------


def test_rotation_is_degenerate_with_period_2():
    # A = 2 R(90 deg): A^2 = -4 I, C sees x1: needs an arrival at both parities -> sigma = (1-lambda)^(1/2)
    r = run([[0, -2], [2, 0]], [[1, 0]], BERN("1/2"))
    (b,) = r.blocks
    assert b.degenerate and b.period == 2 and b.certified
    assert r.critical_arrival_probability_exact == "15/16"  # 4 (1 - lambda)^(1/2) = 1


def test_jordan_block_non_degenerate():
    r = run([[2, 1], [0, 2]], [[1, 0]], BERN("0.8"))
    (b,) = r.blocks
    assert b.jordan_sizes == (2,) and not b.degenerate and r.critical_arrival_probability_exact == "3/4"


def test_jordan_head_unobservable_is_never_stable():
    r = run([[2, 1], [0, 2]], [[0, 1]], BERN("0.99"))
    (b,) = r.blocks
    assert r.verdict == "unstable" and b.sigma == 1.0 and b.degenerate
    assert r.critical_arrival_probability is None and any("no arrival probability" in w for w in r.warnings)


def test_repeated_jordan_blocks_need_two_outputs():
    # two Jordan chains of 3/2 (sizes 2 and 1): C_hat has 2 columns; one row cannot observe both
    A = [["3/2", 1, 0], [0, "3/2", 0], [0, 0, "3/2"]]
    r1 = run(A, [[1, 0, 1]], BERN("0.9"))
    assert r1.blocks[0].jordan_sizes == (2, 1) and r1.verdict == "unstable" and r1.blocks[0].sigma == 1.0
    r2 = run(A, [[1, 0, 1], [0, 0, 1]], BERN("0.6"))
    assert not r2.blocks[0].degenerate and r2.critical_arrival_probability_exact == "5/9"


def test_unobservable_unstable_mode():
    r = run([[2, 0], [0, 0.5]], [[0, 1]], BERN("0.9"))
    assert r.verdict == "unstable"


def test_zero_and_stable_eigenvalues():
    r = run([[0, 1, 0], [0, 0, 0], [0, 0, 0.5]], [[1, 0, 0]], BERN("0.1"))
    assert r.verdict == "stable" and r.critical_arrival_probability == 0.0
    assert {b.eigenvalue_texts if hasattr(b, "eigenvalue_texts") else b.eigenvalues for b in r.blocks} == {
        ("1/2",),
        ("0",),
    }


def test_equal_moduli_without_fmo_are_separate_blocks():
    # 5/4 and (3 +- 4i)/4 share |alpha| = 5/4 but no ratio is a root of unity: three non-degenerate
    # FMO blocks (Rohr, Marelli and Fu (2014)'s definition), whereas grouping by modulus alone would call it degenerate.
    A = [["5/4", 0, 0], [0, "3/4", -1], [0, 1, "3/4"]]
    r = run(A, [[1, 1, 0]], BERN("0.5"))
    assert len(r.blocks) == 3 and not any(b.degenerate for b in r.blocks)
    assert r.critical_arrival_probability_exact == "9/25"


def test_complex_pair_with_rational_angle_and_period_4():
    # eigenvalues 1 +- i: ratio i (order 4), |alpha|^2 = 2; one output row: 2 columns, degenerate
    r = run([[1, -1], [1, 1]], [[1, 0]], BERN("0.9"))
    (b,) = r.blocks
    assert b.period == 4 and b.degenerate and b.certified
    # rows r_n = (c1, c2 i^n): no two of the 4 phases are parallel (r_0 = (c1, c2), r_2 = (c1, -c2)),
    # so the largest blind set is one phase: sigma = (1 - lambda)^(3/4), 2 (1 - lambda_c)^(3/4) = 1
    assert r.critical_arrival_probability_exact == "1 - 2**(2/3)/4"
    assert r.critical_arrival_probability == pytest.approx(1 - 2 ** (-4 / 3), rel=1e-14)


def test_irrational_modulus():
    # eigenvalues (1 +- sqrt 5)/2, golden ratio phi: lambda_c = 1 - 1/phi^2 = 1/phi = 0.618...
    r = run([[1, 1], [1, 0]], [[1, 0]], BERN("0.5"))
    phi = (1 + 5**0.5) / 2
    assert r.critical_arrival_probability == pytest.approx(1 / phi, rel=1e-12)
    assert r.verdict == "unstable" and r.blocks[0].certified
    assert run([[1, 1], [1, 0]], [[1, 0]], BERN("0.62")).verdict == "stable"


def test_assumption_1_is_enforced():
    with pytest.raises(AssumptionViolation, match="Assumption 1") as e:
        run([[2]], [[1]], BERN(1))
    assert e.value.field == "/channel/arrival_probability"
    with pytest.raises(AssumptionViolation) as e:
        run([[2]], [[1]], GE(0, "1/2"))
    assert e.value.field == "/channel/failure_rate"


def test_report_shape():
    d = run([[1.25, 0], [1, 1.1]], [[1, 1]], BERN(0.5)).to_dict()
    assert d["verdict"] == "stable" and d["critical_arrival_probability"] == 0.36
    b = d["blocks"][0]
    for key in (
        "eigenvalues",
        "modulus",
        "modulus_exact",
        "jordan_sizes",
        "period",
        "degenerate",
        "sigma",
        "rate",
        "verdict",
    ):
        assert key in b
    assert b["eigenvalues"] == ["5/4"] and b["modulus_exact"] == "5/4" and b["rate"] == pytest.approx(0.78125)
    assert d["assumptions"] == [] and d["warnings"] == []
    json.dumps(d, allow_nan=False)


# --- invariances (hypothesis) -------------------------------------------------------

BASES = [
    ([[2, 0], [0, -2]], [[1, 1]], GE("1/3", "2/5")),
    ([[0, -2], [2, 0]], [[1, 0]], BERN("7/10")),
    (
        [[2, 1], [0, 2]],
        [[1, 0], [1, 1]],
        {"model": "markov", "order": 2, "arrival_probability": {"00": "1/3", "01": "1/2", "10": "1/4", "11": "4/5"}},
    ),
    ([["3/2", 0, 0], [0, "-3/2", 0], [0, 0, "1/2"]], [[1, 1, 1], [1, 2, 0]], BERN("2/5")),
    ([["5/4", 0], [1, "11/10"]], [[1, 1]], GE("1/5", "1/2")),
]


def _transform(A, C, seed, scale_rows):
    rng = random.Random(seed)
    n = len(A)
    while True:
        T = sympy.Matrix(n, n, lambda i, j: rng.randint(-2, 2) + (3 if i == j else 0))
        if T.det() != 0:
            break
    Ti = T.inv()
    A2 = T * sympy.Matrix([[sympy.Rational(str(x)) for x in r] for r in A]) * Ti
    C2 = sympy.Matrix([[sympy.Rational(str(x)) for x in r] for r in C]) * Ti
    rows = [[str(C2[i, j] * sympy.Rational(scale_rows[i % len(scale_rows)])) for j in range(n)] for i in range(C2.rows)]
    rng.shuffle(rows)
    return [[str(x) for x in A2.row(i)] for i in range(n)], rows


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    case=st.sampled_from(range(len(BASES))),
    seed=st.integers(0, 10**6),
    scale=st.lists(st.sampled_from(["1", "-2", "3/7", "5"]), min_size=1, max_size=3),
)
def test_similarity_and_row_scaling_invariance(case, seed, scale):
    A, C, ch = BASES[case]
    ref = run(A, C, ch)
    A2, C2 = _transform(A, C, seed, scale)
    got = run(A2, C2, ch)
    assert got.verdict == ref.verdict
    assert got.critical_arrival_probability_exact == ref.critical_arrival_probability_exact
    key = lambda b: (round(b.modulus, 9), sorted(b.eigenvalues))  # noqa: E731
    for b1, b2 in zip(sorted(ref.blocks, key=key), sorted(got.blocks, key=key)):
        assert b1.eigenvalues == b2.eigenvalues or sorted(b1.eigenvalues) == sorted(b2.eigenvalues)
        assert b1.degenerate == b2.degenerate and b1.period == b2.period
        assert (b1.sigma is None and b2.sigma is None) or b1.sigma == pytest.approx(b2.sigma, abs=1e-12)


def test_markov_rate_with_repeated_zero_eigenvalues_and_irrational_modulus():
    # Regression: the one-period transfer matrix of "no arrivals" under an order-2 channel has
    # eigenvalues (P(0|00)^2, 0, 0, 0); the Perron root must not be read off a repeated zero.
    # Lemma 2: rate = |alpha|^2 P(0|00) with |alpha|^2 = (29 + sqrt 57)/8 ... = 4.5687
    ch = {
        "model": "markov",
        "order": 2,
        "arrival_probability": {"00": "9/20", "01": "13/20", "10": "17/20", "11": "9/10"},
    }
    r = run([["-2", "-1"], ["-1/2", "3/2"]], [[1, 1]], ch)
    assert r.verdict == "unstable" and r.blocks[0].rate == pytest.approx(4.568729304408843 * 0.55)
    assert [b.verdict for b in r.blocks] == ["unstable", "unstable"]


def test_controllability_matches_the_full_krylov_rank():
    # the incremental FLINT rank against SymPy's rank of the whole [Q, AQ, ..., A^(n-1) Q]
    import random
    from fractions import Fraction as F

    import sympy

    from kfio.model._types import System
    from kfio.stability._verdict import _controllable

    rng = random.Random(5)
    seen = set()
    for _ in range(120):
        n = rng.randint(1, 5)
        A = [[F(rng.randint(-2, 2), rng.choice([1, 2, 3])) for _ in range(n)] for _ in range(n)]
        k = rng.randint(1, n)  # Q = G G' of rank <= k, often not controllable
        G = [[F(rng.choice([0, 0, 1, -1, 2])) for _ in range(k)] for _ in range(n)]
        Q = [[sum((G[i][t] * G[j][t] for t in range(k)), F(0)) for j in range(n)] for i in range(n)]
        system = System(A=tuple(map(tuple, A)), C=((F(1),) + (F(0),) * (n - 1),), Q=tuple(map(tuple, Q)), R=((F(1),),))
        SA, SQ = sympy.Matrix(A), sympy.Matrix(Q)
        K = sympy.Matrix.hstack(*[SA**j * SQ for j in range(n)])
        expected = K.rank() == n
        assert _controllable(system) is expected
        seen.add(expected)
    assert seen == {True, False}
