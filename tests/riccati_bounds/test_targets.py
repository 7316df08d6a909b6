"""Smallest arrival probability meeting a certified trace(V_bar) target (Sinopoli et al. 2004, Theorems 4 and 6).

Independent route: for a scalar plant ``V_bar = T`` solves the MARE
``T = a^2 T + q - lambda a^2 T^2 / (T + r)`` exactly when
``lambda = (a^2 T + q - T)(T + r) / (a^2 T^2)``.  For a 2x2 plant, a grid scan
of ``trace V_bar`` brackets the bisection's answer.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from kfio import InvalidInput, load_request
from kfio.riccati_bounds import compute_bounds
from kfio.riccati_bounds._riccati import v_bar
from kfio.riccati_bounds._targets import smallest_arrival_for_trace


@pytest.mark.parametrize("a, q, r, T", [(-1.25, 1.0, 2.5, 10.0), (1.1, 2.0, 1.0, 5.0), (2.0, 1.0, 1.0, 40.0)])
def test_scalar_closed_form(a, q, r, T):
    res = smallest_arrival_for_trace(np.array([[a]]), np.array([[1.0]]), np.array([[q]]), np.array([[r]]), T, tol=1e-9)
    lam = (a * a * T + q - T) * (T + r) / (a * a * T * T)
    assert res.sufficient == pytest.approx(lam, abs=2e-9) and res.insufficient <= lam + 1e-12
    assert res.trace_at_sufficient <= T


def test_two_states_against_grid_scan():
    A = np.array([[1.25, 0], [1, 1.1]])
    C, Q, R = np.array([[1.0, 1.0]]), 20 * np.eye(2), np.array([[2.5]])
    res = smallest_arrival_for_trace(A, C, Q, R, 400.0, tol=1e-7)
    grid = np.linspace(0.5, 0.99, 50)
    ok = [lam for lam in grid if (V := v_bar(A, C, Q, R, lam)) is not None and np.trace(V) <= 400.0]
    below = [lam for lam in grid if lam not in ok]
    assert max(below) < res.sufficient <= min(ok)
    assert np.trace(v_bar(A, C, Q, R, res.sufficient)) <= 400.0 * (1 + 1e-9)


def test_unreachable_target():
    res = smallest_arrival_for_trace(np.array([[2.0]]), np.array([[1.0]]), np.array([[1.0]]), np.array([[1.0]]), 0.5)
    assert res.sufficient is None and not res.reachable


def _request(**bounds):
    body = {
        "system": {"A": [[-1.25]], "C": [[1]], "Q": [[1]], "R": [[2.5]]},
        "channel": {"model": "bernoulli", "arrival_probability": 0.6},
        "options": {"bounds": bounds},
    }
    return load_request(json.dumps(body))


def test_in_the_bounds_report():
    rep = compute_bounds(_request(trace_target=10))
    d = rep.to_dict()["trace_target"]
    assert d["smallest_arrival_probability"] == pytest.approx(0.53, abs=1e-5)
    assert "smallest arrival probability with certified trace(V_bar) <= 10" in rep.summary()


def test_bad_target():
    with pytest.raises(InvalidInput, match="trace_target must be positive") as e:
        compute_bounds(_request(trace_target="-1"))
    assert e.value.field == "/options/bounds/trace_target"
