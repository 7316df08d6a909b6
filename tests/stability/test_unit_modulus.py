"""Blocks with ``|alpha| = 1`` are not "below one": Theorem 1 of Rohr, Marelli and Fu (2014) decides them.

Only blocks with ``|alpha| < 1`` may be reported stable without computing ``sigma``.  A mode
on the unit circle that no packet observes has ``sigma = 1``, so its rate
``|alpha|^2 sigma`` is exactly 1: the theorem's boundary case, never "stable"
(the ``unit-modulus-skipped`` mutant, which skips ``|alpha| <= 1`` blocks, calls ``A = [[1]], C = [[0]]`` stable).
"""

from __future__ import annotations

from fractions import Fraction

import pytest

import kfio


@pytest.mark.parametrize(
    ("A", "C"),
    [
        ([[1]], [[0]]),  # alpha = 1, unobserved
        ([[-1]], [[0]]),  # alpha = -1
        ([[0, -1], [1, 0]], [[0, 0]]),  # alpha = +-i: a rotation by a quarter turn
        ([[1, 1], [0, 1]], [[0, 0]]),  # a Jordan block at 1
    ],
)
@pytest.mark.parametrize("channel", [kfio.bernoulli(0.5), kfio.gilbert_elliott(failure_rate=0.2, recovery_rate=0.7)])
def test_an_unobserved_unit_circle_mode_is_boundary(A, C, channel) -> None:
    r = kfio.analyze(kfio.System(A=A, C=C), channel)
    assert r.verdict == "boundary"
    (block,) = r.blocks
    # every arrival sequence leaves the mode blind: P(blind for t steps) = 1, sigma = 1, rate = 1^2 * 1
    assert (block.modulus, block.sigma, block.rate, block.verdict) == (1.0, 1.0, 1.0, "boundary")
    assert block.certified


@pytest.mark.parametrize(("p", "verdict"), [("1/2", "stable"), ("2/3", "stable")])
def test_an_observed_unit_mode_has_rate_one_minus_p(p, verdict) -> None:
    # A = 1 seen through C = 1: a blind step happens with probability 1 - p, so rate = 1^2 (1 - p) < 1
    r = kfio.analyze(kfio.System(A=[[1]], C=[[1]]), kfio.bernoulli(p))
    assert r.verdict == verdict
    assert r.blocks[0].sigma_exact is not None and r.blocks[0].rate == pytest.approx(float(1 - Fraction(p)))


def test_inside_the_unit_disc_stays_stable_without_sigma() -> None:
    r = kfio.analyze(kfio.System(A=[[0.999]], C=[[0]]), kfio.bernoulli(0.5))
    assert r.verdict == "stable" and r.blocks[0].sigma is None
