"""Short forms of long exact numbers in human summaries; ``--json`` keeps the exact text."""

from __future__ import annotations

import json
import re
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
import sympy
from sympy import CRootOf, Rational, sqrt

from kfio.model import parse_request
from kfio.service.cli import main
from kfio.stability import analyze
from kfio.structure._display import SHORT_TEXT_CHARS, algebraic_degree, short_text
from kfio.structure._eigen import X

PENDULUM = Path(__file__).resolve().parents[2] / "examples" / "pendulum_c2d.json"


@pytest.mark.parametrize(
    "expr, degree",
    [
        (Rational(9, 25), 1),
        (1 - 1 / sqrt(2), 2),
        (1 - 1 / CRootOf(X**3 - 3 * X - 1, 2) ** 2, 3),
        (sqrt(2) + sqrt(3), 4),
    ],
)
def test_algebraic_degree_of_hand_worked_numbers(expr, degree) -> None:
    # 1 - 1/sqrt(2): 2x^2 - 4x + 1; sqrt(2) + sqrt(3): x^4 - 10x^2 + 1; a rational function of a
    # root of the irreducible x^3 - 3x - 1 that is not rational has degree 3
    assert algebraic_degree(expr) == degree


def test_short_texts_stay_and_long_ones_shrink() -> None:
    assert short_text("9/25", 0.36) == "9/25"
    long = "1 - 1/CRootOf(" + "7" * 60 + "*x**3 - x + 1, 0)"
    assert short_text(long, 0.1260772, 3) == "root of a degree-3 polynomial, 0.126077"
    assert short_text(long, 0.1260772) == "algebraic number, 0.126077"
    assert short_text(long, 0.1260772, 3, max_chars=len(long)) == long
    eig = "root of x**4 - " + "1" * 40 + "/3 near 0.5+0.25i"
    assert short_text(eig, 0.5 + 0.25j) == "root of a degree-4 polynomial, 0.5+0.25i"
    rad = "9*sqrt(7571919976557716011523931590)/25000000000000000 + 5002452700498431/5000000000000000"
    assert short_text(rad, 1.0318) == "root of a degree-2 polynomial, 1.0318"


def _pendulum() -> dict:
    return json.loads(PENDULUM.read_text())


def test_pendulum_example_is_a_discretized_pendulum() -> None:
    """The example's ``A`` is ``expm(Ac dt)`` of a pendulum with an actuator lag, dt = 0.01."""
    from scipy.linalg import expm

    Ac = np.array([[0, 1, 0], [9.81, -0.5, 1.0], [0, -1.0, -2.0]])
    assert np.allclose(np.array(_pendulum()["system"]["A"]), expm(Ac * 0.01), rtol=0, atol=1e-15)


def test_pendulum_summary_is_short_and_json_exact(capsys) -> None:
    report = analyze(parse_request(_pendulum()))
    exact = report.critical_arrival_probability_exact
    assert len(exact) > 200 and "CRootOf" in exact
    # independent route: the characteristic polynomial of the exact A is an irreducible cubic,
    # and lambda_c = 1 - 1/alpha^2 for its one root outside the unit circle (non-degenerate block)
    A = sympy.Matrix([[Rational(Fraction(repr(v))) for v in row] for row in _pendulum()["system"]["A"]])
    factors = sympy.factor_list(A.charpoly(X).as_expr(), X)[1]
    assert [sympy.degree(f, X) for f, _ in factors] == [3]
    alpha = max(abs(z) for z in np.roots([float(c) for c in sympy.Poly(factors[0][0], X).all_coeffs()]))
    assert report.critical_arrival_probability == pytest.approx(1 - 1 / alpha**2, rel=1e-12)

    summary = report.summary()
    # kfio's one number format: the decimal, then what the long exact text is (it stays in the JSON)
    (line,) = [ln for ln in summary.splitlines() if ln.startswith("critical arrival probability: ")]
    m = re.fullmatch(r"critical arrival probability: (\S+) \(algebraic, degree (\d+), from float data\)", line)
    assert m, line
    assert float(m.group(1)) == pytest.approx(1 - 1 / alpha**2, rel=1e-5)
    assert m.group(1) == f"{report.critical_arrival_probability:.6g}"
    assert int(m.group(2)) == sympy.degree(factors[0][0], X) == 3
    assert "CRootOf" not in summary and "root of x" not in summary
    assert max(len(line) for line in summary.splitlines()) < 160
    assert report.to_dict()["critical_arrival_probability_exact"] == exact

    assert main(["analyze", str(PENDULUM)]) == 0
    out, _ = capsys.readouterr()
    assert out.strip() == summary.strip()
    assert main(["analyze", "--json", str(PENDULUM)]) == 0
    out, _ = capsys.readouterr()
    data = json.loads(out)
    assert data["critical_arrival_probability_exact"] == exact
    assert all(len(t) > SHORT_TEXT_CHARS for b in data["blocks"] for t in b["eigenvalues"])
