"""Simulation spot checks of the exact region on both sides of its boundary.

Liu and Goldsmith (2004)'s last example (Section VI.B-C): ``A = [[1.25, 0], [1, 1.1]]``,
``C_1 = [1 0]``, ``C_2 = [1 1]``, ``Q = 20 I``, ``R = 2.5 I``.  The exact
region is ``lambda_2 > 21/121`` (mode 1.1, seen by packet 2 only) and
``(1 - lambda_1)(1 - lambda_2) < 16/25`` (mode 1.25).  Three points that
Liu and Goldsmith (2004)'s bounds leave undecided:

=================  =========  ===========================  =========
point              exact      largest block rate           bounds
=================  =========  ===========================  =========
(1/4, 1/4)         stable     1.21 * 3/4 = 0.9075          undecided
(9/20, 1/20)       unstable   1.21 * 19/20 = 1.1495        undecided
(3/10, 1/10)       unstable   1.21 * 9/10 = 1.089          undecided
=================  =========  ===========================  =========

Monte Carlo (:func:`kfio.simulation._simulate.simulate`, 4000 trajectories, 120
steps, fixed seeds) estimates ``E[trace P_t]``; we fit its per-step growth by
least squares on ``log`` over ``t = 20..100`` (or ``20..120``).

Why not the exact finite-horizon mean: ``2^(2T)`` sequences cap ``T`` at 10,
and with ``P_0 = Q = 20 I`` the mean is still in its transient there on both
sides (measured growth of the last step: x1.150 at the stable point,
x1.167 and x1.229 at the unstable ones), so it cannot tell them apart.

Tolerances.  Near or past the threshold ``trace P_t`` is heavy-tailed and the
sample mean *underestimates* ``E[trace P_t]`` once the rare long loss runs
that carry it (probability ``(1 - lambda_2)^t``) fall below one in 4000.  At
``(9/20, 1/20)`` they remain well sampled up to ``t = 100``
(``0.95^100 * 4000 ~ 24`` trajectories), and the fitted growth is within
0.03 (in log) of the exact rate (measured: 1.146-1.151 over four seeds).  At
``(3/10, 1/10)`` (``0.9^100 * 4000 < 1``) it is not, so we only ask for
clear growth, ``> 1.03`` (measured 1.062-1.077).  At ``(1/4, 1/4)`` the mean
levels off: ``< 1.02`` (measured 0.993-1.009).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from kfio.design._regions import sensor_thresholds
from kfio.riccati_bounds._compute import compute_bounds
from kfio.simulation._simulate import simulate

from support.bruteforce_sensors import SEED000, sensor_request

STEPS, TRAJECTORIES = 120, 4000


def growth(point: tuple[str, str], seed: int, start: int = 20, end: int = 100) -> float:
    A, Cs = SEED000["last"]
    opts = {"simulate": {"steps": STEPS, "trajectories": TRAJECTORIES, "seed": seed}}
    rep = simulate(sensor_request(A, Cs, list(point), options=opts))
    if rep.mean_diverged_at is not None:
        end = min(end, rep.mean_diverged_at - 1)
    t = np.arange(start, end + 1)
    y = np.log(np.asarray(rep.mean_trace[start : end + 1], dtype=float))
    return float(np.exp(np.polyfit(t, y, 1)[0]))


def exact_side(point: tuple[str, str]) -> tuple[str, float]:
    A, Cs = SEED000["last"]
    req = sensor_request(A, Cs, list(point))
    assert compute_bounds(req).verdict == "undecided"  # the bounds leave it open
    th = sensor_thresholds(req)
    return th.verdict, max(th.block_rates)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1])
def test_stable_side_levels_off(seed: int) -> None:
    verdict, rate = exact_side(("1/4", "1/4"))
    assert verdict == "stable" and rate == pytest.approx(0.9075)
    assert growth(("1/4", "1/4"), seed, 20, STEPS) < 1.02


@pytest.mark.parametrize("seed", [0, 1])
def test_unstable_side_grows_at_the_exact_rate(seed: int) -> None:
    verdict, rate = exact_side(("9/20", "1/20"))
    assert verdict == "unstable" and rate == pytest.approx(1.1495)
    assert abs(math.log(growth(("9/20", "1/20"), seed)) - math.log(rate)) < 0.03


@pytest.mark.parametrize("seed", [0, 1])
def test_unstable_side_near_the_boundary_grows(seed: int) -> None:
    verdict, rate = exact_side(("3/10", "1/10"))
    assert verdict == "unstable" and rate == pytest.approx(1.089)
    assert growth(("3/10", "1/10"), seed) > 1.03
