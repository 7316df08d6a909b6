"""The 95% band of the Monte Carlo mean is ``mean +- 1.96 s / sqrt(M)``, checked against brute force.

``kfio.simulation`` documents the band as the normal approximation
``mean +- z_0.975 s / sqrt(M)`` with the sample standard deviation ``s`` of the
``M`` trajectories (lower end clipped at 0).  For a scalar plant the law of
``P_t`` is a finite mixture over the ``2^t`` arrival sequences, so its exact
standard deviation is a sum the test computes itself.  The band's half-width
must match ``1.96 sd / sqrt(M)`` within the sampling error of ``s`` (a few per
cent at ``M = 20000``); a band half as wide (the ``band-halved`` mutant) is off by 50%.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import kfio

A, C, Q, R, LAM = 1.2, 1.0, 1.0, 1.0, 0.6
STEPS, M = 8, 20_000
Z = 1.959963984540054  # the 0.975 quantile of the standard normal


def exact_moments() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Mean and standard deviation of the predictor ``P(t|t-1)`` and the filtered ``P(t|t)``, t = 0..STEPS.

    Riccati recursion of Sinopoli et al. (2004), eq. (10)-(11), for the scalar plant:
    ``P(t|t) = P - g P^2 C^2 / (C^2 P + R)`` with ``g = 1`` on arrival, and
    ``P(t+1|t) = A^2 P(t|t) + Q``; ``P(0|-1) = Q``.  The filtered value at ``t`` uses the arrival at ``t``.
    """
    pred = [[] for _ in range(STEPS + 1)]
    filt = [[] for _ in range(STEPS + 1)]
    for seq in itertools.product((0, 1), repeat=STEPS + 1):
        w, P = 1.0, Q
        for t, g in enumerate(seq):
            pred[t].append((w, P))
            w *= LAM if g else 1 - LAM
            Pf = P - g * P * P * C * C / (C * C * P + R)
            filt[t].append((w, Pf))
            P = A * A * Pf + Q

    def moments(rows):
        mean = np.array([sum(w * x for w, x in r) for r in rows])
        var = np.array([sum(w * x * x for w, x in r) for r in rows]) - mean**2
        return mean, np.sqrt(np.maximum(var, 0.0))

    # row t repeats each prefix once per continuation of the sequence: normalizing the weights
    # of each row gives the exact law of P at t
    def normalized(rows):
        total = [sum(w for w, _ in r) for r in rows]
        return [[(w / s, x) for w, x in r] for r, s in zip(rows, total)]

    return (*moments(normalized(pred)), *moments(normalized(filt)))


@pytest.fixture(scope="module")
def report():
    system = kfio.System(A=[[A]], C=[[C]], Q=[[Q]], R=[[R]])
    return kfio.simulate(system, kfio.bernoulli(LAM), steps=STEPS, trajectories=M, seed=7)


def _check_band(mean, low, high, exact_mean, exact_sd) -> None:
    low, high, mean = np.asarray(low, float), np.asarray(high, float), np.asarray(mean, float)
    half = high - mean
    expected = Z * exact_sd / math.sqrt(M)
    ok = exact_sd > 0
    assert np.all(half[~ok] == 0)
    ratio = half[ok] / expected[ok]
    assert np.all((ratio > 0.85) & (ratio < 1.15)), ratio
    assert np.allclose(mean - low, np.minimum(half, mean))  # symmetric, clipped at 0
    # and the band covers the exact mean at most steps (95% each, 9 steps)
    assert np.sum((low <= exact_mean) & (exact_mean <= high)) >= 7


def test_the_band_half_width_is_1_96_sd_over_sqrt_m(report) -> None:
    pm, psd, _, _ = exact_moments()
    low, high = report.ci95
    _check_band(report.mean_trace, low, high, pm, psd)
    d = report.to_dict()
    _check_band(d["mean_trace"], d["ci95_low"], d["ci95_high"], pm, psd)


def test_the_filtered_band_half_width_is_1_96_sd_over_sqrt_m(report) -> None:
    _, _, fm, fsd = exact_moments()
    f = report.to_dict()["filtered"]
    _check_band(f["mean_trace"], f["ci95_low"], f["ci95_high"], fm, fsd)
