"""Goodness of fit on run lengths: do the fitted model's loss and arrival bursts look like the trace's?

A model chosen by likelihood may still be wrong in the way that matters for
stability: the length of loss bursts.  A Bernoulli channel has geometric loss
runs with mean ``1 / lambda``; a Gilbert-Elliott arrival chain geometric ones
with mean ``1 / q`` (Gilbert 1960); a hidden-state channel (Elliott 1963: losses
in both states) has runs no observable chain of low order reproduces.  Here
the law of the run length ``L`` under a fitted chain of order ``k`` is
computed exactly from the chain (in floats), and the trace's complete runs
(those not cut by its ends) are compared with it by Pearson's chi-square test
on binned counts, every bin expecting at least :data:`MIN_EXPECTED` runs.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats

#: Smallest expected count of a bin (the usual validity rule of Pearson's test).
MIN_EXPECTED = 5.0
#: Run lengths are tabulated up to this before the rest is one tail bin.
MAX_LENGTH = 10_000


def complete_runs(arrivals: np.ndarray, symbol: int) -> np.ndarray:
    """Lengths of the maximal runs of ``symbol`` that neither start nor end the trace (those are cut short)."""
    a = np.asarray(arrivals, dtype=np.int8)
    is_s = np.concatenate(([0], (a == symbol).astype(np.int8), [0]))
    edges = np.diff(is_s)
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1)
    keep = (starts > 0) & (ends < a.size)
    return (ends - starts)[keep]


def _stationary(P: np.ndarray) -> np.ndarray:
    k = P.shape[0]
    A = np.vstack([P.T - np.eye(k), np.ones(k)])
    b = np.zeros(k + 1)
    b[-1] = 1.0
    pi, *_ = np.linalg.lstsq(A, b, rcond=None)
    pi = np.clip(pi, 0.0, None)
    return np.asarray(pi / pi.sum())


def run_length_law(table: Sequence[float], symbol: int, max_length: int = MAX_LENGTH) -> np.ndarray:
    """``law[l - 1] = P(L = l)``, ``l = 1 ..``, for runs of ``symbol`` under the chain ``table``.

    The array stops where the remaining mass is below ``1e-15``, or at ``max_length``.

    ``table[h] = P(1 | h)`` for the histories of order ``k = log2(len(table))``
    (kfio's convention); a Bernoulli table ``(lambda,)`` is read as the order-1
    table ``(lambda, lambda)``.  A run starts where the stationary chain emits
    ``symbol`` after the other symbol; it lasts while the chain keeps emitting it.
    """
    t = np.asarray([float(x) for x in table], dtype=float)
    if t.size == 1:
        t = np.array([t[0], t[0]])
    k = int(t.size).bit_length() - 1
    mask = (1 << k) - 1
    stay = t if symbol == 1 else 1.0 - t  # P(next = symbol | h)
    n = t.size
    P = np.zeros((n, n))
    for h in range(n):
        P[h, ((h << 1) | 1) & mask] += t[h]
        P[h, (h << 1) & mask] += 1.0 - t[h]
    pi = _stationary(P)
    v = np.zeros(n)
    for h in range(n):
        if (h & 1) != symbol:  # the last packet was the other symbol: a run of `symbol` may start
            v[((h << 1) | symbol) & mask] += pi[h] * stay[h]
    total = v.sum()
    law = np.zeros(max_length)
    if total <= 0:
        return law
    v /= total
    targets = ((np.arange(n) << 1) | symbol) & mask
    for length in range(max_length):
        law[length] = float(np.dot(v, 1.0 - stay))
        w = np.zeros(n)
        np.add.at(w, targets, v * stay)
        v = w
        if v.sum() < 1e-15:  # what is left is below float resolution of the total
            return law[: length + 1]
    return law


@dataclass(frozen=True)
class RunTest:
    """Pearson's chi-square test of the run lengths of one symbol against a model's law.

    ``bins`` are ``[first, last]`` run lengths (``last`` ``None``: and longer),
    ``observed`` and ``expected`` their counts; ``p_value`` is ``None`` when
    too few runs leave fewer than two degrees of freedom.
    """

    runs: int
    mean_length: float | None
    model_mean_length: float | None
    bins: tuple[tuple[int, int | None], ...]
    observed: tuple[int, ...]
    expected: tuple[float, ...]
    statistic: float | None
    dof: int | None
    p_value: float | None

    def as_dict(self) -> dict[str, Any]:
        """The JSON object of the test."""
        return {
            "runs": self.runs,
            "mean_length": self.mean_length,
            "model_mean_length": self.model_mean_length,
            "bins": [list(b) for b in self.bins],
            "observed": list(self.observed),
            "expected": list(self.expected),
            "statistic": self.statistic,
            "dof": self.dof,
            "p_value": self.p_value,
        }


def run_test(arrivals: np.ndarray, table: Sequence[float], symbol: int, fitted: int) -> RunTest:
    """The chi-square test of the complete runs of ``symbol`` against ``run_length_law(table, symbol)``.

    ``fitted`` is the number of estimated parameters the law depends on; the
    degrees of freedom are ``bins - 1 - fitted``.
    """
    lengths = complete_runs(arrivals, symbol)
    law = run_length_law(table, symbol)
    lengths_axis = np.arange(1, law.size + 1)
    model_mean = float(np.dot(law, lengths_axis)) if law.sum() > 0 else None
    R = int(lengths.size)
    if R == 0:
        return RunTest(0, None, model_mean, (), (), (), None, None, None)
    observed_by_length = np.bincount(np.minimum(lengths, law.size), minlength=law.size + 1)[1:]
    expected_by_length = R * law
    bins: list[tuple[int, int | None]] = []
    obs: list[int] = []
    exp: list[float] = []
    start = 0
    acc_e = 0.0
    acc_o = 0
    tail_e = float(expected_by_length.sum())
    for i in range(law.size):
        acc_e += float(expected_by_length[i])
        acc_o += int(observed_by_length[i])
        tail_e -= float(expected_by_length[i])
        if acc_e >= MIN_EXPECTED and tail_e >= MIN_EXPECTED:
            bins.append((start + 1, i + 1))
            obs.append(acc_o)
            exp.append(acc_e)
            start, acc_e, acc_o = i + 1, 0.0, 0
    rest_o = R - sum(obs)
    rest_e = float(R - sum(exp))
    bins.append((start + 1, None))
    obs.append(rest_o)
    exp.append(rest_e)
    dof = len(bins) - 1 - fitted
    statistic = p_value = None
    if dof >= 1 and all(e > 0 for e in exp):
        statistic = float(sum((o - e) ** 2 / e for o, e in zip(obs, exp)))
        p_value = float(stats.chi2.sf(statistic, dof))
    return RunTest(
        R,
        float(lengths.mean()),
        model_mean,
        tuple(bins),
        tuple(obs),
        tuple(exp),
        statistic,
        dof if dof >= 1 else None,
        p_value,
    )


__all__ = ["MIN_EXPECTED", "RunTest", "complete_runs", "run_length_law", "run_test"]
