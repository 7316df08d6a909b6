"""The Monte Carlo / exact agreement line: steps with a zero-width band are set apart, not failed.

At ``t = 0`` every trajectory starts from the same ``P0``: the sample's standard error is the
rounding of the sums (``1e-21`` against a mean of ``4e-4``), and a ``z`` computed against it (44.7
in the case that prompted this) says nothing about agreement.  Such steps are counted apart and
checked for equality to rounding instead.
"""

from __future__ import annotations

import numpy as np

from kfio.simulation import simulate
from kfio.simulation._simulate import DETERMINISTIC_SEM, agreement_line

from support.factories import bern, make

SCALAR = {"A": [[1.1]], "C": [[1]], "Q": [[0.0004]], "R": [[1]]}


def test_the_first_step_is_deterministic_and_set_apart() -> None:
    rep = simulate(make(SCALAR, bern(0.6), {"steps": 6, "trajectories": 3000, "seed": 3, "exact_steps": 6}))
    agree = rep.exact_agreement()
    assert agree is not None
    sem, mean, exact = rep.stats.sem, rep.stats.mean, rep.exact.mean_trace
    # independently: the steps whose band is rounding-wide are exactly those with every trajectory alike
    alike = [t for t in range(7) if sem[t] <= DETERMINISTIC_SEM * max(abs(mean[t]), abs(exact[t]))]
    assert alike == [0]  # P_0 = P0 = Q for every trajectory; from t = 1 the arrivals differ
    assert agree["deterministic_steps"] == 1 and agree["deterministic_equal"] == 1
    assert agree["steps_compared"] == 7
    z = np.abs(mean[1:] - exact[1:]) / sem[1:]
    assert agree["within_ci95"] == int((z <= 1.959963984540054).sum())
    assert agree["max_abs_z"] == max(z)
    line = agreement_line(agree, 6)
    assert f"at {agree['within_ci95']} of 6 random steps" in line
    assert "1 step with a zero-width band (every trajectory alike) skipped: equal to the exact value" in line
    assert line in rep.summary()


def test_a_deterministic_step_that_differs_is_said() -> None:
    agree = {
        "steps_compared": 5,
        "within_ci95": 3,
        "max_abs_z": 2.5,
        "deterministic_steps": 2,
        "deterministic_equal": 1,
    }
    line = agreement_line(agree, 4)
    assert "at 3 of 3 random steps" in line and "1 of them NOT equal to the exact value" in line


def test_without_deterministic_steps_the_line_is_the_plain_one() -> None:
    agree = {
        "steps_compared": 9,
        "within_ci95": 9,
        "max_abs_z": 1.1,
        "deterministic_steps": 0,
        "deterministic_equal": 0,
    }
    assert agreement_line(agree, 8) == "exact E[P_t] (t <= 8): inside the 95% band at 9 of 9 steps (max |z| = 1.1)"
