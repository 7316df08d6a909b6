"""Maximum-likelihood channel models of a trace, from transition counts, as exact rationals.

For a Markov chain of order ``k`` on the arrivals (Bernoulli is ``k = 0``,
the Gilbert-Elliott arrival chain ``k = 1``) the likelihood of a trace given
its first ``k`` symbols is ``prod_h P(1|h)^n(h->1) (1 - P(1|h))^n(h->0)``,
maximized by ``P(1|h) = n(h->1) / n(h->*)`` (the estimates of Yajnik, Moon, Kurose
and Towsley 1999).  So
``lambda = #1 / N``, ``p = n(1->0) / n(1->*)``, ``q = n(0->1) / n(0->*)``.
Histories are integers whose ``k`` bits, most significant first, are
``a[t-k] .. a[t-1]``: kfio's Markov table convention
(:class:`kfio.model.MarkovChannel`), so the key ``"01"`` is history 1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

#: The candidate models, by order: ``0`` Bernoulli, ``1`` Gilbert-Elliott, ``2..`` Markov.
MODEL_NAMES = {0: "bernoulli", 1: "gilbert_elliott"}


def model_name(order: int) -> str:
    """``"bernoulli"``, ``"gilbert_elliott"`` or ``"markov"``."""
    return MODEL_NAMES.get(order, "markov")


def history_key(h: int, order: int) -> str:
    """The request key of history ``h``: ``order`` characters of 0/1, oldest first."""
    return format(h, f"0{order}b") if order else ""


def transition_counts(arrivals: np.ndarray, order: int, start: int | None = None) -> np.ndarray:
    """``counts[h, a]``: how often history ``h`` (of ``order`` packets) was followed by ``a``.

    Positions ``t = start .. N-1`` are counted (``start`` defaults to
    ``order``, the first position with a whole history).
    """
    a = arrivals.astype(np.int64)
    first = order if start is None else start
    if a.size <= first:
        return np.zeros((1 << order, 2), dtype=np.int64)
    h = np.zeros(a.size - first, dtype=np.int64)
    for j in range(1, order + 1):  # bit order - j of the history is a[t - j]
        h |= a[first - j : a.size - j] << (j - 1)
    nxt = a[first:]
    counts: np.ndarray = np.bincount(2 * h + nxt, minlength=2 << order).reshape(1 << order, 2)
    return counts


def estimates(counts: np.ndarray) -> tuple[Fraction | None, ...]:
    """``P(1 | h) = n(h->1) / n(h->*)`` per history, exact; ``None`` for a history never seen."""
    return tuple(Fraction(int(c[1]), int(c[0] + c[1])) if c[0] + c[1] else None for c in counts)


def log_likelihood(counts: np.ndarray) -> float:
    """``sum_h sum_a n(h->a) log P_hat(a | h)`` at the maximum-likelihood estimates (``0 log 0 = 0``)."""
    total = 0.0
    for n0, n1 in counts.tolist():
        n = n0 + n1
        for m in (n0, n1):
            if m:
                total += m * math.log(m / n)
    return total


@dataclass(frozen=True)
class Candidate:
    """One fitted model: its order, counts on the whole trace, and its score on the common positions.

    Attributes
    ----------
    order:
        ``0`` Bernoulli, ``1`` Gilbert-Elliott, ``k >= 2`` Markov of order ``k``.
    counts:
        ``counts[h, a]`` over the whole trace (positions ``order .. N-1``): the estimates.
    table:
        ``P(1 | h)`` per history (``None`` where ``h`` never occurs).
    log_likelihood, bic:
        On the positions ``K .. N-1`` shared by every candidate (``K`` the
        largest order tried), so that the scores compare like with like;
        ``None`` when some history never occurs there.
    """

    order: int
    counts: np.ndarray
    table: tuple[Fraction | None, ...]
    log_likelihood: float | None
    bic: float | None

    @property
    def model(self) -> str:
        return model_name(self.order)

    @property
    def parameters(self) -> int:
        """``d = 2^k`` free probabilities."""
        return 1 << self.order

    @property
    def complete(self) -> bool:
        """Every history occurs, so every probability has an estimate."""
        return all(x is not None for x in self.table)


def candidate(arrivals: np.ndarray, order: int, common_start: int) -> Candidate:
    """Fit the order-``order`` chain and score it by BIC on positions ``common_start .. N-1``.

    ``BIC = -2 log L + d log n`` with ``d = 2^order`` and ``n`` the number of
    scored positions (Schwarz 1978); the smaller, the better.
    """
    counts = transition_counts(arrivals, order)
    table = estimates(counts)
    scored = transition_counts(arrivals, order, start=common_start)
    n = int(scored.sum())
    if n == 0 or any(c[0] + c[1] == 0 for c in scored.tolist()):
        return Candidate(order, counts, table, None, None)
    ll = log_likelihood(scored)
    return Candidate(order, counts, table, ll, -2 * ll + (1 << order) * math.log(n))


__all__ = [
    "Candidate",
    "candidate",
    "estimates",
    "history_key",
    "log_likelihood",
    "model_name",
    "transition_counts",
]
