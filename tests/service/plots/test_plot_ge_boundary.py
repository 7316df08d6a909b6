"""The Gilbert-Elliott boundary drawn under a (p, q) sweep is the --ge-plot curve, and that curve is exact.

Reproducer: a 20 x 20 sweep of (failure rate p, recovery rate q) for
``A = 1.25 diag(1, -1)``, ``C = [1 1]`` drew its "exact boundary" by sorting
sampled curve points by p, so the fold of the curve (p reaches 0.463 at
q = 0.77) zigzagged between p = 0.41 and 0.46.
"""

from __future__ import annotations

import json
from fractions import Fraction

import numpy as np
import pytest
import sympy

from kfio import analyze, load_request
from kfio.design._ge_boundary import boundary_lines
from kfio.design._ge_region import GeStructure, _u, critical_on_line
from kfio.service.plots import GE_BOUNDARY_GID, ge_region_figure
from kfio.service.sweep_plot import sweep_figure
from kfio.sweep import load_sweep, run_sweep

BASE = {
    "system": {"A": [["5/4", 0], [0, "-5/4"]], "C": [[1, 1]]},
    "channel": {"model": "gilbert_elliott", "failure_rate": "3/10", "recovery_rate": "1/2"},
}


def _boundary_points(fig) -> list[np.ndarray]:
    (ax,) = fig.axes
    return [np.asarray(ln.get_xydata(), dtype=float) for ln in ax.get_lines() if ln.get_gid() == GE_BOUNDARY_GID]


@pytest.fixture(scope="module")
def report():
    return analyze(load_request(json.dumps({**BASE, "options": {"analyze": {"ge_grid": 5}}})))


@pytest.fixture(scope="module")
def sweep_lines():
    # p on the x axis: the axis along which the curve folds back (the reproducer's orientation)
    spec = load_sweep(
        json.dumps(
            {
                "command": "analyze",
                "base": BASE,
                "axes": [
                    {"pointer": "/channel/failure_rate", "values": ["1/4", "3/4"], "name": "p"},
                    {"pointer": "/channel/recovery_rate", "values": ["1/4", "3/4"], "name": "q"},
                ],
            }
        )
    )
    return _boundary_points(sweep_figure(run_sweep(spec, engine="serial")))


def test_sweep_boundary_is_the_ge_plot_curve_at_every_drawn_point(report, sweep_lines) -> None:
    ge = np.concatenate(_boundary_points(ge_region_figure(report.gilbert_elliott, report.verdict, report_request())))
    drawn = np.concatenate([pts[np.isfinite(pts).all(axis=1)] for pts in sweep_lines])[:, ::-1]  # (p, q) -> (q, p)
    assert len(drawn) > 50
    gap = np.hypot(drawn[:, None, 0] - ge[None, :, 0], drawn[:, None, 1] - ge[None, :, 1]).min(axis=1)
    assert gap.max() <= 1e-6
    back = np.hypot(ge[:, None, 0] - drawn[None, :, 0], ge[:, None, 1] - drawn[None, :, 1]).min(axis=1)
    assert back.max() <= 1e-6  # and the --ge-plot draws no point the sweep plot leaves out


def test_sweep_boundary_follows_the_fold_without_zigzag(sweep_lines) -> None:
    (line,) = sweep_lines
    line = line[np.isfinite(line).all(axis=1)]  # the None that ends the line
    p, q = line[:, 0], line[:, 1]
    # the curve turns back in p at its maximum p = 0.4632... (q = 0.77): the reproducer's numbers
    k = int(np.argmax(p))
    assert 0.463 < p[k] < 0.4633 and q[k] == pytest.approx(0.77, abs=0.01)
    # consecutive vertices are neighbours along the curve (the zigzag jumped across the fold)
    assert np.hypot(np.diff(p), np.diff(q)).max() < 0.03
    # and every vertex lies on (25/16)^2 ((1 - q)^2 + p q) = 1 (Rohr, Marelli and Fu 2014, Theorem 1 for this class)
    np.testing.assert_allclose((25 / 16) ** 2 * ((1 - q) ** 2 + p * q), 1.0, atol=1e-12)


def test_drawn_boundary_points_are_exact_critical_rates(report) -> None:
    """Each drawn (q, p) is q*(p) or p*(q), computed exactly (CRootOf) on the line through it."""
    structure = GeStructure(report.gilbert_elliott.patterns)
    (line,) = _boundary_points(ge_region_figure(report.gilbert_elliott, report.verdict, report_request()))
    for q, p in line[:: max(1, len(line) // 12)]:
        on_q = critical_on_line(structure, "q", Fraction(p).limit_denominator(10**9)).crossings
        on_p = critical_on_line(structure, "p", Fraction(q).limit_denominator(10**9)).crossings
        err = min([abs(c.value - q) for c in on_q] + [abs(c.value - p) for c in on_p])
        assert err < 1e-6, (q, p)


def test_one_recurrence_for_exact_float_and_symbolic_values() -> None:
    """``u_k = P(lost at t + k | lost at t)``: the k-th power of the channel's transition matrix, in every number type."""
    p, q = Fraction(3, 10), Fraction(2, 7)
    T = sympy.Matrix([[1 - p, p], [q, 1 - q]])  # states (arrived, lost)
    for k in range(1, 7):
        exact = (T**k)[1, 1]
        assert _u(k, p, q) == Fraction(str(exact))
        assert float(_u(k, np.array(float(p)), np.array(float(q)))) == pytest.approx(float(exact), rel=1e-14)
        P, Q = sympy.symbols("p q")
        assert _u(k, P, Q, sympy.expand).subs({P: sympy.Rational(3, 10), Q: sympy.Rational(2, 7)}) == exact


def test_boundary_lines_are_empty_when_the_whole_square_is_stable() -> None:
    r = analyze(load_request(json.dumps({**BASE, "system": {"A": [["1/2"]], "C": [[1]]}})))
    assert boundary_lines(GeStructure(r.gilbert_elliott.patterns)) == ()


def report_request():
    return load_request(json.dumps(BASE))
