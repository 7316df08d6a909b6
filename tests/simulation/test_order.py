"""Percentiles by nested selection (``kfio.simulation._order``) against ``numpy.quantile(method="inverted_cdf")``."""

from __future__ import annotations

import numpy as np
import pytest

from kfio.simulation._order import order_indices, order_statistics

Q = np.array([0.5, 0.9, 0.99])


@pytest.mark.parametrize("M", [1, 2, 3, 7, 10, 99, 100, 101, 999, 1000, 12345, 100_001])
def test_same_numbers_as_numpy_quantile(M) -> None:
    rng = np.random.default_rng(M)
    ranks = order_indices(M, Q)
    for x in (
        np.exp(3 * rng.normal(size=M)),  # heavy tailed
        rng.integers(0, 5, size=M).astype(float),  # many ties
        np.where(rng.random(M) < 0.05, np.inf, rng.random(M)),  # diverged trajectories
    ):
        want = np.quantile(x, Q, method="inverted_cdf")
        before = x.copy()
        assert np.array_equal(order_statistics(x, ranks), want)
        assert np.array_equal(x, before)  # not modified unless asked
        assert np.array_equal(order_statistics(x, ranks, overwrite=True), want)
        assert np.array_equal(np.sort(x), np.sort(before))  # reordered, same values


def test_nan_gives_nan_as_numpy_does() -> None:
    x = np.array([1.0, np.nan, 3.0, 2.0])
    with np.errstate(invalid="ignore"):
        want = np.quantile(x, Q, method="inverted_cdf")
    assert np.isnan(want).all()
    assert np.isnan(order_statistics(x, order_indices(4, Q))).all()


def test_ranks_are_the_sorted_positions() -> None:
    x = np.arange(200.0)[::-1].copy()
    ranks = order_indices(200, Q)
    assert order_statistics(x, ranks).tolist() == [float(k) for k in ranks]
    assert ranks == (99, 179, 197)  # ceil(200 q) - 1
