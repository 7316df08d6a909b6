"""The in-place statistics of the simulation give numpy's floats bit for bit.

Each new path is compared with the one it replaced, written here as it was:
``numpy`` mean, ``std(ddof=1)`` and ``quantile(method="inverted_cdf")`` on a copy
with the diverged trajectories at ``+inf`` (per step); ``unpack(h).mean(axis=0)``
and the ``einsum`` trace of the unpacked batch (final step); one ``numpy.sort``
and ``numpy.quantile`` per quantile, and Hill's estimate on its own sort
(stationary report).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from kfio.simulation._order import order_indices
from kfio.simulation._packed import PackedRiccatiStep
from kfio.simulation._stationary import QUANTILES, Z95, hill, stationary_report
from kfio.simulation._step_stats import TraceRecorder

PERCENTS = np.array([0.5, 0.9, 0.99])


def old_record(tr: np.ndarray, alive: np.ndarray) -> tuple[float, float, np.ndarray]:
    x = np.where(alive, tr, np.inf)
    mean, std = (float(x.mean()), float(x.std(ddof=1))) if alive.all() else (math.nan, math.nan)
    pct = np.full(3, np.nan) if np.isnan(x).any() else np.quantile(x, PERCENTS, method="inverted_cdf")
    return mean, std, pct


def traces_case(rng: np.random.Generator, M: int) -> np.ndarray:
    kind = rng.integers(4)
    if kind == 0:  # heavy tail
        return 3.0 + rng.pareto(1.2, M) * 10.0 ** rng.integers(0, 8)
    if kind == 1:  # ties: a lattice of values, as a few arrival histories give
        return 2.25 ** rng.integers(0, 12, M) + 0.5
    if kind == 2:  # wide dynamic range
        return np.exp(rng.normal(0, 20, M))
    return rng.random(M)


def same(a: float, b: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or a == b


@pytest.mark.parametrize("seed", range(6))
def test_recorder_equals_numpy(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for _ in range(25):
        M = int(rng.integers(2, 3000))
        rec = TraceRecorder(M, order_indices(M, PERCENTS))
        for _ in range(3):  # the buffers are reused from step to step
            tr = traces_case(rng, M)
            alive = np.ones(M, dtype=bool)
            if rng.random() < 0.3:
                alive[rng.integers(0, M, size=int(rng.integers(1, 4)))] = False
            if rng.random() < 0.2:  # a trajectory that turned non-finite this step
                tr[rng.integers(M)] = [np.inf, np.nan][int(rng.integers(2))]
            before = tr.copy()
            with np.errstate(all="ignore"):
                mean, std, pct = rec.record(tr, alive, bool(alive.all()))
                want = old_record(tr, alive)
            assert same(mean, want[0]) and same(std, want[1])
            assert np.array_equal(pct, want[2], equal_nan=True)
            assert np.array_equal(tr, before, equal_nan=True)  # left unchanged


def test_packed_mean_and_traces_equal_the_unpacked_batch() -> None:
    rng = np.random.default_rng(7)
    for n, M in [(1, 2), (1, 9001), (2, 4096), (2, 4097), (3, 10_000), (4, 8193), (7, 1234), (12, 5000)]:
        step = PackedRiccatiStep.build(rng.normal(size=(n, n)), np.eye(n), rng.normal(size=(1, n)), np.eye(1))
        X = rng.normal(size=(M, n, n)) * np.exp(rng.normal(0, 6, size=(M, 1, 1)))
        h = step.pack(X @ X.transpose(0, 2, 1))
        P = step.unpack(h)
        assert np.array_equal(step.mean(h), P.mean(axis=0)), (n, M)
        assert np.array_equal(step.traces(h), np.einsum("mii->m", P)), (n, M)
        h2 = np.ascontiguousarray(h[:, ::-1])  # a second batch summed beside the first
        both = step.means(h, h2)
        assert np.array_equal(both[0], P.mean(axis=0)) and np.array_equal(both[1], step.unpack(h2).mean(axis=0))


def test_initial_traces_of_the_broadcast_start() -> None:
    """The run's first record takes ``trace(P0)`` once, where the broadcast batch gave it per trajectory."""
    rng = np.random.default_rng(8)
    for n in (1, 2, 3, 6, 13, 40):
        X = rng.normal(size=(n, n)) * 10.0 ** rng.integers(-5, 5, size=(n, 1))
        P0 = X @ X.T
        batch = np.broadcast_to(P0, (50, n, n))
        assert np.array_equal(np.einsum("mii->m", batch), np.full(50, np.einsum("mii->m", P0[None])[0]))


def old_quantile_ci(x: np.ndarray, q: float) -> tuple[float, float, float]:
    M = x.size
    s = np.sort(x)
    j = int(math.floor(M * q - Z95 * math.sqrt(M * q * (1 - q))))
    k = int(math.ceil(M * q + Z95 * math.sqrt(M * q * (1 - q))))
    value = float(np.quantile(s, q, method="inverted_cdf"))
    lo = float(s[max(j, 0)]) if j >= 0 else 0.0
    hi = float(s[min(k, M - 1)]) if k < M else math.inf
    return value, lo, hi


def old_hill(samples: np.ndarray) -> tuple[float | None, int]:
    x = np.sort(samples[np.isfinite(samples) & (samples > 0)])[::-1]
    k = samples.size // 20
    if k < 10 or x.size <= k:
        return None, k
    logs = np.log(x[:k]) - math.log(x[k])
    mean = float(logs.mean())
    return (1.0 / mean if mean > 0 else None), k


@pytest.mark.parametrize("seed", range(8))
def test_stationary_report_equals_one_sort_per_quantile(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    for _ in range(10):
        M = int(rng.integers(2, 5000))
        x, xf = traces_case(rng, M), traces_case(rng, M)
        x[rng.integers(0, M, size=int(rng.integers(0, 3)))] = np.inf  # diverged
        if rng.random() < 0.3:  # zeros (P0 = 0), or most trajectories diverged: Hill's estimate has too few samples
            x[rng.integers(0, M, size=int(rng.integers(1, M)))] = [0.0, np.inf][int(rng.integers(2))]
        rep = stationary_report(x, 9, (1.0, 100.0), None, xf)
        assert rep.quantiles == tuple((q, *old_quantile_ci(x, q)) for q in QUANTILES)
        assert rep.filtered_quantiles == tuple((q, *old_quantile_ci(xf, q)) for q in QUANTILES)
        assert (rep.hill, rep.hill_k) == old_hill(x)
        assert hill(x) == old_hill(x)
