"""Per-step statistics of ``trace(P_t)`` over the trajectories, on buffers allocated once per run.

At every step the simulation reports the sample mean, the sample standard
deviation (``ddof = 1``) and the inverted-CDF percentiles (Hyndman and Fan
(1996), definition 1) of the ``M`` traces, a diverged trajectory counting as
``+inf``.  :class:`TraceRecorder` returns the same floats as
``x.mean()``, ``x.std(ddof=1)`` and ``numpy.quantile(x, q,
method="inverted_cdf")``: it performs numpy's own operations in numpy's order
(one pairwise sum of ``x``, a division by ``M``, the squared deviations and
their pairwise sum, a division by ``M - 1``, a square root; the order statistics
selected as in :mod:`kfio.simulation._order`).  What it avoids is numpy's
temporaries: each of them is a fresh ``M``-float array, and at ``M = 10^5``
(800 KB, above the allocator's threshold for reusing memory) every one is new
memory from the kernel, page faults included, which cost more than the
arithmetic.  Here the deviations and the array reordered by the selection are
two buffers reused at every step.
"""

from __future__ import annotations

import math

import numpy as np

from ._order import order_statistics, select_in_place


class TraceRecorder:
    """Mean, standard deviation and order statistics ``ranks`` of ``M`` traces, step after step.

    Parameters
    ----------
    M:
        Number of trajectories.
    ranks:
        0-based ranks of the order statistics (:func:`kfio.simulation._order.order_indices`).

    Examples
    --------
    >>> import numpy as np
    >>> from kfio.simulation._order import order_indices
    >>> x = np.array([3.0, 1.0, 2.0, 5.0])
    >>> rec = TraceRecorder(4, order_indices(4, np.array([0.5])))
    >>> mean, std, pct = rec.record(x, np.ones(4, dtype=bool), True)
    >>> (mean, std, pct.tolist()) == (x.mean(), x.std(ddof=1), [2.0])
    True
    """

    def __init__(self, M: int, ranks: tuple[int, ...]) -> None:
        self.M, self.ranks = M, ranks
        self._sorted_ranks = sorted(set(ranks))
        self._select = np.empty(M)
        self._dev = np.empty(M)

    def record(self, tr: np.ndarray, alive: np.ndarray, all_alive: bool) -> tuple[float, float, np.ndarray]:
        """Statistics of ``tr`` with the trajectories not ``alive`` as ``+inf`` (``tr`` is left unchanged).

        ``all_alive`` must be ``alive.all()`` (the caller keeps count).  The mean and
        the standard deviation are NaN unless every trajectory is alive.
        """
        if not all_alive:
            x = np.where(alive, tr, np.inf)
            return math.nan, math.nan, order_statistics(x, self.ranks, overwrite=True)
        M, dev = self.M, self._dev
        total = np.add.reduce(tr)  # x.mean(): the pairwise sum, divided by M
        mean = total / M
        np.subtract(tr, mean, out=dev)  # x.std(ddof=1): squared deviations from that mean, their sum over M - 1
        np.square(dev, out=dev)
        var = np.add.reduce(dev) / (M - 1)
        y = self._select
        np.copyto(y, tr)
        if np.isfinite(total):  # no NaN (nor inf) among the traces: select without looking for one
            select_in_place(y, self._sorted_ranks)
            pct = y[list(self.ranks)]
        else:
            pct = order_statistics(y, self.ranks, overwrite=True)
        return float(mean), float(np.sqrt(var)), pct


__all__ = ["TraceRecorder"]
