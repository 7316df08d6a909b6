"""Exact percentiles of a batch by selection: what ``numpy.quantile(x, q, method="inverted_cdf")`` returns.

The inverted-CDF percentile of ``M`` samples is an order statistic ``x_(k)``
(Hyndman and Fan (1996), definition 1).  ``numpy.quantile`` selects all the
requested ``k`` with one multi-pivot ``partition``; selecting them one at a
time, each in the part of the array left of or right of the previous one, in
the order that visits the fewest elements (``M + 0.5 M + 0.1 M`` for the 50th,
90th and 99th percentiles), is about 5x cheaper and returns the same numbers
bit for bit, since an order statistic does not depend on how it was found.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np


def order_indices(M: int, q: np.ndarray) -> tuple[int, ...]:
    """The ranks ``k`` (0-based) with ``x_(k)`` the inverted-CDF ``q``-quantile of ``M`` samples.

    Taken from ``numpy.quantile`` itself, on ``0, 1, ..., M - 1``, so that the
    rounding of ``M q`` is numpy's (remembered per ``M`` and ``q``: at
    ``M = 10^5`` the call costs about a millisecond).
    """
    return _order_indices(M, tuple(float(x) for x in np.atleast_1d(q)))


@lru_cache(maxsize=64)
def _order_indices(M: int, q: tuple[float, ...]) -> tuple[int, ...]:
    return tuple(int(k) for k in np.quantile(np.arange(M, dtype=float), np.array(q), method="inverted_cdf"))


def order_statistics(x: np.ndarray, ranks: tuple[int, ...], overwrite: bool = False) -> np.ndarray:
    """``x_(k)`` for each ``k`` in ``ranks`` (ascending): ``numpy.quantile(x, q, method="inverted_cdf")``.

    ``x`` is reordered in place if ``overwrite``, else left unchanged.  With a
    NaN in ``x`` numpy's answer is NaN throughout, and so is this one.

    Examples
    --------
    >>> import numpy as np
    >>> x = np.array([5.0, 1.0, 4.0, 2.0, 3.0])
    >>> ks = order_indices(5, np.array([0.5, 0.9]))
    >>> ks, order_statistics(x, ks).tolist()
    ((2, 4), [3.0, 5.0])
    """
    if np.isnan(x).any():
        return np.full(len(ranks), np.nan)
    y = x if overwrite else x.copy()
    select_in_place(y, sorted(set(ranks)))
    return y[list(ranks)]


def select_in_place(y: np.ndarray, ks: list[int]) -> None:
    """Reorder ``y`` so that ``y[k]`` is its order statistic ``y_(k)`` for every ``k`` in ``ks`` (sorted, no NaN in ``y``)."""
    _select(y, ks, 0, len(y))


def _select(y: np.ndarray, ks: list[int], lo: int, hi: int) -> None:
    """Put ``y[k]`` in place for every ``k`` in ``ks`` (sorted, inside ``lo:hi``), touching only ``y[lo:hi]``."""
    if not ks:
        return
    i = _first_pivot(tuple(ks), lo, hi)
    k = ks[i]
    y[lo:hi].partition(k - lo)
    _select(y, ks[:i], lo, k)
    _select(y, ks[i + 1 :], k + 1, hi)


@lru_cache(maxsize=256)
def _first_pivot(ks: tuple[int, ...], lo: int, hi: int) -> int:
    """Which of ``ks`` to select first in ``y[lo:hi]`` so that the partitions visit the fewest elements.

    A partition of ``m`` elements costs about ``m`` visits; selecting ``k_i`` first
    leaves ``k_1..k_(i-1)`` in ``lo:k_i`` and the rest in ``k_i + 1:hi``.  For the
    50th, 90th and 99th percentiles: the 50th first (``M + 0.5 M + 0.1 M``), not
    the 90th (``M + 0.9 M + 0.1 M``).
    """
    return min(range(len(ks)), key=lambda i: _visits(ks[:i], lo, ks[i]) + _visits(ks[i + 1 :], ks[i] + 1, hi))


@lru_cache(maxsize=256)
def _visits(ks: tuple[int, ...], lo: int, hi: int) -> int:
    if not ks:
        return 0
    i = _first_pivot(ks, lo, hi)
    return hi - lo + _visits(ks[:i], lo, ks[i]) + _visits(ks[i + 1 :], ks[i] + 1, hi)


__all__ = ["order_indices", "order_statistics", "select_in_place"]
