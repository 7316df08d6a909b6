"""Independent brute force for ``sigma``: ``P(blind after t steps)`` by dynamic programming.

Shares nothing with :mod:`kfio.sigma._sigma` or :mod:`kfio.search._blind`: it reads
the raw fields of a :class:`~kfio.structure._phases.PhaseBlock` and the tables of
the channels, and follows the definition of Rohr, Marelli and Fu (2014), eq. (14) and (33).
The state after ``t`` steps is (set of covered slots as a bitmask, joint
channel history); the phase ``t mod N0`` is implicit.  A covered set whose
stacked rows reach full column rank is dropped (no longer blind).  Then

    P(blind after t) = sum of the state vector,

and ``sigma^N0`` is the ratio ``P(blind after (k+1) N0) / P(blind after k N0)``
for large ``k``: the one-period DP matrix ``D`` is squared ``log2 k`` times
(with rescaling), which is the same DP run for ``k N0`` steps.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence

import numpy as np

from kfio.model._types import MarkovChannel
from kfio.structure._phases import PhaseBlock

State = tuple[int, tuple[int, ...]]


class BlindDP:
    """The covered-set DP of one block under independent per-group channels."""

    def __init__(self, block: PhaseBlock, channels: Sequence[MarkovChannel], rtol: float = 1e-8) -> None:
        self.N0 = block.base_period
        self.G = len(block.row_groups)
        self.L = block.c_hat.shape[1]
        self.channels = list(channels)
        expo = np.asarray(block.exponents, dtype=float)
        self.rows = {}
        for n in range(self.N0):
            omega = np.exp(2j * np.pi * ((expo * n) % self.N0) / self.N0)
            for g, idx in enumerate(block.row_groups):
                self.rows[n * self.G + g] = block.c_hat[list(idx), :] * omega[None, :]
        self.rtol = rtol
        self._blind: dict[int, bool] = {}
        self.histories = list(itertools.product(*[range(1 << ch.order) for ch in channels]))

    def blind(self, mask: int) -> bool:
        """Whether the slots of ``mask`` lack full column rank ``L``."""
        if mask not in self._blind:
            blocks = [self.rows[i] for i in range(self.N0 * self.G) if mask >> i & 1]
            if not blocks:
                self._blind[mask] = True
            else:
                s = np.linalg.svd(np.vstack(blocks), compute_uv=False)
                self._blind[mask] = int((s > self.rtol * max(1.0, s[0])).sum()) < self.L
        return self._blind[mask]

    def step(self, n: int, state: State) -> list[tuple[State, float]]:
        """Blind successors of ``state`` at phase ``n`` and their probabilities."""
        mask, hist = state
        out = []
        for emit in itertools.product((0, 1), repeat=self.G):
            p = 1.0
            new_mask = mask
            new_hist = []
            for g, (ch, h, e) in enumerate(zip(self.channels, hist, emit)):
                p1 = float(ch.table[h])
                p *= p1 if e else 1.0 - p1
                if e:
                    new_mask |= 1 << (n * self.G + g)
                new_hist.append(((h << 1) | e) & ((1 << ch.order) - 1) if ch.order else 0)
            if self.blind(new_mask):
                out.append(((new_mask, tuple(new_hist)), p))
        return out

    def initial(self) -> dict[State, float]:
        """Nothing covered; joint history uniform (any positive start has the same rate)."""
        return {(0, h): 1.0 / len(self.histories) for h in self.histories}

    def blind_probability(self, t: int) -> float:
        """``P(blind after t steps)`` by running the DP forward."""
        dist = self.initial()
        for step in range(t):
            nxt: dict[State, float] = {}
            for state, p in dist.items():
                for s2, q in self.step(step % self.N0, state):
                    nxt[s2] = nxt.get(s2, 0.0) + p * q
            dist = nxt
        return sum(dist.values())

    def period_matrix(self) -> tuple[list[State], np.ndarray]:
        """One-period DP matrix on the phase-0 states reachable from :meth:`initial`."""
        start = list(self.initial())
        index = {s: i for i, s in enumerate(start)}
        rows: list[dict[State, float]] = []
        i = 0
        while i < len(start):
            dist = {start[i]: 1.0}
            for n in range(self.N0):
                nxt: dict[State, float] = {}
                for state, p in dist.items():
                    for s2, q in self.step(n, state):
                        nxt[s2] = nxt.get(s2, 0.0) + p * q
                dist = nxt
            for s2 in dist:
                if s2 not in index:
                    index[s2] = len(start)
                    start.append(s2)
            rows.append(dist)
            i += 1
        D = np.zeros((len(start), len(start)))
        for r, dist in enumerate(rows):
            for s2, p in dist.items():
                D[r, index[s2]] += p
        return start, D


def period_ratio(dp: BlindDP, doublings: int = 20) -> float:
    """``P(blind after (k+1) N0) / P(blind after k N0)`` with ``k = 2**doublings``."""
    states, D = dp.period_matrix()
    init = dp.initial()
    v = np.array([init.get(s, 0.0) for s in states])
    M = D.copy()
    for _ in range(doublings):
        M = M @ M
        M /= M.max()
    v = v @ M
    v /= v.sum()
    return float((v @ D).sum() / v.sum())


def oracle_sigma(block: PhaseBlock, channels: Sequence[MarkovChannel], doublings: int = 20) -> float:
    """``sigma = (P(blind after (k+1) N0) / P(blind after k N0))^(1 / N0)``."""
    dp = BlindDP(block, channels)
    return period_ratio(dp, doublings) ** (1.0 / dp.N0)
