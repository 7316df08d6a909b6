"""Exact partial-loss regions: Liu and Goldsmith (2004)'s cases, the one-sensor case, the bounds, the API.

The exact region is an *extension* of Rohr, Marelli and Fu (2014), Theorem 1 (docs/theory.md,
"Beyond the seeds"), so every closed form asserted here was first checked by
an independent route: the brute-force blind probability of
:mod:`bruteforce_sensors` (floating-point eigenvectors and a covered-set DP,
nothing shared with the analyzer), by bisection to ``1e-7``; and Liu and Goldsmith (2004)'s
bounds (``kfio bounds``), between which the exact answer must lie.

Liu and Goldsmith (2004)'s numbers, checked:

* Case 1 (Section VI.A): ``lambda_2c = max(0, 1 - 1/(1.25^2 (1 - lambda_1)))``
  is right (``alpha = 1.25``, both packets see every mode, so only the
  all-lost pattern is blind).
* Case 2: the same curve (one unstable mode, seen by both packets).
* Section VI.B: ``lambda_1 > 0.84 = 21/25`` and ``lambda_2 > 5/9`` are exact;
  "5/9 ~ 0.56" is a rounding, not a threshold.
* Section VI.C: ``lambda_1 = lambda_2 = 0.25`` is *stable*; on the budget line
  ``lambda_1 + lambda_2 = 0.5`` the filter is stable iff
  ``lambda_2 > 21/121``, set by the mode ``1.1`` that only packet 2 sees.
"""

from __future__ import annotations

import json
from fractions import Fraction as F

import pytest
import sympy

from kfio import InvalidInput, analyze, load_request
from kfio.design._regions import exact_region_grid, region_report, sensor_thresholds
from kfio.riccati_bounds._compute import compute_bounds

from support.bruteforce_sensors import SEED000, critical_probability, sensor_request

#: Tolerance of the brute-force bisection against exact values.
ORACLE_TOL = 1e-6


def exact(text: str) -> sympy.Expr:
    """Our own exact output back to SymPy (trusted text: never user input)."""
    return sympy.sympify(text)


def system(name: str) -> tuple[list, list]:
    return SEED000[name]


def numeric(name: str):
    import numpy as np

    A, Cs = SEED000[name]
    C = np.array([row for rows in Cs for row in rows], dtype=float)
    groups, k = [], 0
    for rows in Cs:
        groups.append(list(range(k, k + len(rows))))
        k += len(rows)
    return np.array(A, dtype=float), C, groups


# -- Liu and Goldsmith (2004), Section VI.A: Cases 1 and 2 -------------------------------------


def case1_closed_form(lam1: F) -> sympy.Expr:
    """Liu and Goldsmith (2004), Case 1: ``max(0, 1 - 1/(alpha^2 (1 - lambda_1)))`` with ``alpha = 5/4``."""
    v = 1 - 1 / (sympy.Rational(25, 16) * (1 - sympy.Rational(lam1.numerator, lam1.denominator)))
    return sympy.Max(0, v)


@pytest.mark.parametrize("name", ["case1", "case2"])
@pytest.mark.parametrize("lam1", [F(0), F(1, 10), F(1, 5), F(1, 3), F(9, 25), F(1, 2)])
def test_case1_case2_closed_form(name: str, lam1: F) -> None:
    A, Cs = system(name)
    oracle = critical_probability(*numeric(name), [float(lam1), 0.5], sensor=1)
    assert oracle is not None and abs(oracle - float(case1_closed_form(lam1))) < ORACLE_TOL  # the seed is right
    if lam1 == 0:
        return  # outside Rohr, Marelli and Fu (2014)'s Assumption 1: the request parser's job, not this one's
    th = sensor_thresholds(sensor_request(A, Cs, [lam1, F(1, 2)]))
    t = th.thresholds[1]
    assert exact(t.critical_exact) == case1_closed_form(lam1)
    assert t.status == ("threshold" if lam1 < F(9, 25) else "zero")
    assert th.certified


@pytest.mark.parametrize("name", ["case1", "case2"])
def test_case1_case2_boundary_curve(name: str) -> None:
    A, Cs = system(name)
    curve = exact_region_grid(sensor_request(A, Cs, ["1/2", "1/2"]), 2).curve
    seg = curve.envelope.segments
    assert curve.envelope.lambda_1_min_exact == "0"
    assert [(s.start_exact, s.end_exact) for s in seg] == [("0", "9/25"), ("9/25", "1")]
    lam = sympy.Symbol("lambda_1")
    piece = curve.pieces[seg[0].piece]
    assert sympy.simplify(exact(piece.formula.split("=", 1)[1]) - (1 - 1 / (sympy.Rational(25, 16) * (1 - lam)))) == 0
    assert seg[1].piece is None  # h = 0: any lambda_2 > 0 once lambda_1 > 9/25


def test_case2_bounds_meet_the_exact_curve() -> None:
    """Liu and Goldsmith (2004), Case 2: the bounds coincide, and with the exact threshold."""
    A, Cs = system("case2")
    req = sensor_request(A, Cs, ["1/5", "1/2"])
    crit = compute_bounds(req).critical[1]
    th = sensor_thresholds(req).thresholds[1]
    assert th.critical_exact == "1/5"
    assert crit.lower == pytest.approx(0.2, abs=1e-12)
    assert crit.upper.value is not None and 0.2 <= float(crit.upper.value) <= 0.2 + 1e-5


# -- Liu and Goldsmith (2004), Section VI.B ----------------------------------------------------


def test_diagonal_exact_region() -> None:
    """``A = diag(2.5, 1.5)``: stable iff ``lambda_1 > 21/25`` and ``lambda_2 > 5/9``."""
    A, Cs = system("diagonal")
    th = sensor_thresholds(sensor_request(A, Cs, ["9/10", "3/5"]))
    assert [t.critical_exact for t in th.thresholds] == ["21/25", "5/9"]
    assert th.verdict == "stable" and th.certified
    below = sensor_thresholds(sensor_request(A, Cs, ["4/5", "3/5"]))
    assert below.verdict == "unstable"
    assert below.thresholds[1].status == "none"  # no lambda_2 helps while lambda_1 <= 21/25
    assert below.thresholds[0].critical_exact == "21/25"
    for lam1, expected in ((0.9, 5 / 9), (0.5, None)):
        oracle = critical_probability(*numeric("diagonal"), [lam1, 0.5], sensor=1)
        assert (oracle is None) if expected is None else abs(oracle - expected) < ORACLE_TOL
    curve = exact_region_grid(sensor_request(A, Cs, ["9/10", "3/5"]), 2).curve
    assert curve.envelope.lambda_1_min_exact == "21/25" and curve.envelope.vertical
    assert [curve.pieces[s.piece].formula for s in curve.envelope.segments] == ["lambda_2 = 5/9"]


def test_diagonal_lmi_is_tight_lower_bound_is_not() -> None:
    """Liu and Goldsmith (2004): "the upper bound is tight while the lower bound is loose" (checked at (0.9, 0.6))."""
    A, Cs = system("diagonal")
    rep = compute_bounds(sensor_request(A, Cs, ["9/10", "3/5"]))
    for crit, value in zip(rep.critical, (0.84, 5 / 9)):
        assert crit.upper.value is not None and value <= float(crit.upper.value) <= value + 1e-5
        assert crit.lower < value - 0.2


# -- Liu and Goldsmith (2004), Section VI.C: the last example ----------------------------------


def test_last_example_decided() -> None:
    """``lambda_1 = lambda_2 = 0.25``: undecided by the bounds, exactly stable (rates 225/256 and 363/400)."""
    A, Cs = system("last")
    req = sensor_request(A, Cs, ["1/4", "1/4"])
    assert compute_bounds(req).verdict == "undecided"
    th = sensor_thresholds(req, analyze(req))
    assert th.verdict == "stable" and th.consistent_with_analyze and th.certified
    assert th.block_rates == pytest.approx((1.5625 * 0.75**2, 1.21 * 0.75), rel=1e-12)
    assert [t.critical_exact for t in th.thresholds] == ["11/75", "21/121"]
    for s, value in enumerate((11 / 75, 21 / 121)):
        assert abs(critical_probability(*numeric("last"), [0.25, 0.25], sensor=s) - value) < ORACLE_TOL


def test_last_example_budget_line() -> None:
    """Liu and Goldsmith (2004), VI.C: on ``lambda_1 + lambda_2 = 1/2``, stable iff ``lambda_2 > 21/121``."""
    A, Cs = system("last")
    grid = [F(k, 100) for k in range(1, 50)]
    for lam2 in grid:
        th = sensor_thresholds(sensor_request(A, Cs, [F(1, 2) - lam2, lam2]))
        assert th.verdict == ("stable" if lam2 > F(21, 121) else "unstable"), lam2
    curve = exact_region_grid(sensor_request(A, Cs, ["1/4", "1/4"]), 2).curve
    assert [(s.start_exact, s.end_exact) for s in curve.envelope.segments] == [("0", "141/625"), ("141/625", "1")]
    assert curve.h(0.25) == pytest.approx(21 / 121, abs=1e-15)


# -- containment between Liu and Goldsmith (2004)'s bounds --------------------------------------

CONTAINMENT = {
    **{k: (A, Cs, False) for k, (A, Cs) in SEED000.items()},
    "degenerate": ([[2, 0], [0, -2]], [[[1, 1]], [[1, -1]]], True),
}


@pytest.mark.parametrize("name", sorted(CONTAINMENT))
def test_exact_grid_between_bounds(name: str) -> None:
    """A cell certified stable by the LMI is exactly stable; a cell unstable by the lower bound is not stable.

    A lower-bound cell may be exactly ``boundary`` only where the lower bound holds with equality
    (``prod (1 - lambda_s) rho^2 = 1``): there the theorem is silent and Sinopoli et al. (2004) Theorem 3 says unbounded.
    """
    A, Cs, _ = CONTAINMENT[name]
    req = sensor_request(A, Cs, ["1/2", "1/2"], options={"bounds": {"grid": 7}})
    bounds = compute_bounds(req).region
    grid = exact_region_grid(req, 7)
    assert bounds is not None and bounds.values == grid.values
    rho2 = max(abs(complex(e)) for e in sympy.Matrix(A).applyfunc(sympy.nsimplify).eigenvals()) ** 2
    seen = set()
    for i, a in enumerate(grid.values):
        for j, b in enumerate(grid.values):
            by_bounds, truth = bounds.labels[i][j], grid.labels[i][j]
            seen.add((by_bounds, truth))
            if by_bounds == "stable":
                assert truth == "stable", (a, b)
            elif by_bounds == "unstable":
                assert truth == "unstable" or (truth == "boundary" and abs((1 - a) * (1 - b) * rho2 - 1) < 1e-12), (
                    a,
                    b,
                )
    if name in ("diagonal", "last", "degenerate"):
        assert ("undecided", "stable") in seen or ("undecided", "unstable") in seen  # the grid decides more


@pytest.mark.slow
@pytest.mark.parametrize("name", ["diagonal", "last"])
@pytest.mark.parametrize("point", [("1/4", "1/4"), ("9/10", "3/5"), ("9/20", "1/20"), ("3/10", "1/10")])
def test_thresholds_between_bounds(name: str, point: tuple[str, str]) -> None:
    """Per sensor: closed-form lower bound <= exact lambda_c <= certified LMI value; 'none' only if the LMI finds none."""
    A, Cs = system(name)
    req = sensor_request(A, Cs, list(point))
    th = sensor_thresholds(req)
    for crit, t in zip(compute_bounds(req).critical, th.thresholds):
        if t.status == "none":
            assert crit.upper.value is None
            continue
        assert t.critical is not None and t.critical >= crit.lower - 1e-12
        if crit.upper.value is not None:
            assert t.critical <= float(crit.upper.value)


# -- grid and curve agree -------------------------------------------------------


@pytest.mark.parametrize("name", sorted(SEED000))
def test_grid_matches_curve(name: str) -> None:
    A, Cs = system(name)
    grid = exact_region_grid(sensor_request(A, Cs, ["1/2", "1/2"]), 21)
    for i, a in enumerate(grid.values):
        h = grid.curve.h(float(a))
        for j, b in enumerate(grid.values):
            label = grid.labels[i][j]
            if h is None:
                assert label != "stable"
            elif float(b) > h + 1e-12:
                assert label == "stable", (a, b, h)
            elif float(b) < h - 1e-12:
                assert label == "unstable", (a, b, h)


def test_grid_labels_boundary_cells_exactly() -> None:
    """``lambda_1 = 21/25`` is on the vertical boundary of Section VI.B: exactly ``boundary``, not a float call."""
    A, Cs = system("diagonal")
    g = exact_region_grid(sensor_request(A, Cs, ["1/2", "1/2"]), 3, values=[F(21, 25), F(5, 9), F(9, 10)])
    assert g.labels[0] == ("boundary", "boundary", "boundary")  # lambda_1 = 21/25: block 5/2 has rate 1
    assert g.labels[1] == ("unstable", "unstable", "unstable")  # lambda_1 = 5/9 < 21/25
    assert g.labels[2] == ("stable", "boundary", "stable")  # lambda_2 = 5/9: block 3/2 has rate 1


# -- one sensor reproduces analyze ----------------------------------------------

ONE_PACKET = {
    "scalar": ([[-1.25]], [[1]], "0.4"),
    "seed004_3x3": ([[1.25, 1, 0], [0, 0.9, 7], [0, 0, 0.6]], [[1, 0, 2]], "0.5"),
    "seed004_2x2": ([[1.25, 0], [1, 1.1]], [[1, 1]], "0.3"),
    "example1": ([[2, 0], [0, -2]], [[1, 1]], "0.9"),
    "rotation": ([[0, -2], [2, 0]], [[1, 0]], "0.8"),
    "irrational": ([[1, 1], [1, 0]], [[1, 0]], "0.5"),
    "two_rows": ([[2, 0, 0], [0, -2, 0], [0, 0, 1.5]], [[1, 1, 0], [0, 1, 1]], "0.95"),
}


@pytest.mark.parametrize("name", sorted(ONE_PACKET))
def test_one_sensor_reproduces_analyze(name: str) -> None:
    A, C, lam = ONE_PACKET[name]
    body = {"system": {"A": A, "C": C}, "channel": {"model": "bernoulli", "arrival_probability": lam}}
    plain = load_request(json.dumps(body))
    rep = analyze(plain)
    for req in (plain, sensor_request(A, [C], [lam], noise=False)):
        th = sensor_thresholds(req, rep)
        assert th.verdict == rep.verdict and th.consistent_with_analyze
        t = th.thresholds[0]
        assert t.critical == pytest.approx(rep.critical_arrival_probability, abs=1e-14)
        assert abs(sympy.N(exact(t.critical_exact) - exact(rep.critical_arrival_probability_exact), 50)) < 1e-45
    assert region_report(plain) is None  # one packet: the report already has the critical probability


# -- invariance, report, errors -------------------------------------------------


def test_similarity_and_row_scaling_invariance() -> None:
    """docs/theory.md, "Checks": ``A -> T A T^-1``, ``C -> C T^-1`` and row scaling change nothing."""
    A, Cs = system("last")
    T = sympy.Matrix([[1, 2], [0, 1]])
    At = (T * sympy.Matrix(A).applyfunc(sympy.nsimplify) * T.inv()).tolist()
    Cts = [(sympy.Matrix(C) * T.inv() * k).tolist() for C, k in zip(Cs, (3, -sympy.Rational(1, 2)))]
    as_text = lambda M: [[str(x) for x in row] for row in M]  # noqa: E731
    ref = sensor_thresholds(sensor_request(A, Cs, ["1/4", "1/4"]))
    new = sensor_thresholds(sensor_request(as_text(At), [as_text(C) for C in Cts], ["1/4", "1/4"]))
    assert [t.critical_exact for t in new.thresholds] == [t.critical_exact for t in ref.thresholds]


def test_region_report_shape() -> None:
    A, Cs = system("last")
    req = sensor_request(A, Cs, ["1/4", "1/4"])
    out = region_report(req, report=analyze(req))
    assert out is not None
    assert out["basis"] == "extension" and "not a theorem" in out["statement"]
    assert out["consistent_with_analyze"] is True
    assert [s["critical_arrival_probability_exact"] for s in out["sensors"]] == ["11/75", "21/121"]
    assert out["boundary"]["axes"] == ["s1", "s2"]
    assert len(out["boundary"]["samples"]["lambda_1"]) == len(out["boundary"]["samples"]["lambda_2"])
    json.dumps(out)  # JSON-ready
    three = sensor_request([[2, 0], [0, 3]], [[[1, 0]], [[0, 1]], [[1, 1]]], ["1/2", "1/2", "1/2"], noise=False)
    out3 = region_report(three)
    assert out3 is not None and out3["boundary"] is None and len(out3["sensors"]) == 3


def test_markov_channels_are_refused() -> None:
    A, Cs = system("last")
    ge = {"model": "gilbert_elliott", "failure_rate": "1/4", "recovery_rate": "1/2"}
    req = sensor_request(A, Cs, None, channels={"s1": ge, "s2": {"model": "bernoulli", "arrival_probability": "1/2"}})
    with pytest.raises(InvalidInput, match="i.i.d."):
        sensor_thresholds(req)
    assert region_report(req) is None


def test_grid_errors() -> None:
    A, Cs = system("last")
    req = sensor_request(A, Cs, ["1/4", "1/4"])
    with pytest.raises(InvalidInput, match=">= 2"):
        exact_region_grid(req, 1)
    with pytest.raises(InvalidInput, match="values"):
        exact_region_grid(req, 2, values=[F(1, 2)])
    with pytest.raises(InvalidInput, match=r"\[0, 1\]"):
        exact_region_grid(req, 2, values=[F(1, 2), F(3, 2)])
    three = sensor_request([[2, 0], [0, 3]], [[[1, 0]], [[0, 1]], [[1, 1]]], ["1/2", "1/2", "1/2"], noise=False)
    with pytest.raises(InvalidInput, match="exactly two sensors"):
        exact_region_grid(three, 5)


def test_region_report_reuses_analyze_sigma_results() -> None:
    """Passing ``analyze``'s FMO blocks and sigma results (real channels) gives the same report."""
    from kfio.sigma._sigma import compute_sigma
    from kfio.structure._fmo import fmo_blocks

    A, Cs = system("last")
    req = sensor_request(A, Cs, ["1/4", "1/4"])
    blocks = fmo_blocks(req.system)
    chans = [c for _, c in req.channel.channels]
    sig = [None if b.phase is None or b.modulus_sq_float < 1 else compute_sigma(b.phase, chans) for b in blocks]
    assert region_report(req, fmo=blocks, sigma=sig) == region_report(req)


EXPECTED_EXAMPLES = {
    "regions_seed000_last.json": ["11/75", "21/121"],
    "regions_seed000_diagonal.json": ["21/25", "5/9"],
    "regions_degenerate_swap.json": ["3/8", "0"],
}


@pytest.mark.parametrize("name", sorted(EXPECTED_EXAMPLES))
def test_examples(name: str) -> None:
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "examples" / name
    req = load_request(path.read_text())
    out = region_report(req, report=analyze(req))
    assert out is not None and out["verdict"] == "stable" and out["consistent_with_analyze"]
    assert [s["critical_arrival_probability_exact"] for s in out["sensors"]] == EXPECTED_EXAMPLES[name]
