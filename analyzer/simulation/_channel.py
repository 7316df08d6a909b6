"""The packet channels of a request as one vectorized Markov chain.

Packet ``s`` has a Markov channel of order ``nu_s`` (Rohr, Marelli and Fu (2014), Definition 2;
Bernoulli is ``nu = 0``, Gilbert-Elliott ``nu = 1`` with table ``(q, 1 - p)``).
Its state is the history ``h_s`` of its last ``nu_s`` arrivals, encoded as in
:class:`kfio.model._types.MarkovChannel` (oldest bit most significant).  Packets
are independent, so the joint state is the vector ``(h_1, ..., h_m)`` and

    P(g_t = g | h) = prod_s  P(g_s | h_s),    h_s' = shift(h_s, g_s).

Arrays of joint states have shape ``(..., m)`` (integers); arrival patterns
have the same shape (booleans).  The Monte Carlo samples this chain and the
exact enumeration sums over it; both use the functions here.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from ..model import Packet


@dataclass(frozen=True, eq=False)
class JointChannel:
    """Independent per-packet Markov chains, vectorized over a batch.

    Attributes
    ----------
    tables:
        ``tables[s][h] = P(g_s = 1 | h_s = h)`` as float arrays.
    orders:
        ``nu_s`` per packet.
    stationaries:
        Stationary distribution of each packet's history chain.
    """

    tables: tuple[np.ndarray, ...]
    orders: tuple[int, ...]
    stationaries: tuple[np.ndarray, ...]

    @classmethod
    def from_packets(cls, packets: tuple[Packet, ...]) -> JointChannel:
        return cls(
            tables=tuple(np.array([float(x) for x in pk.channel.table]) for pk in packets),
            orders=tuple(pk.channel.order for pk in packets),
            stationaries=tuple(pk.channel.stationary() for pk in packets),
        )

    @property
    def m(self) -> int:
        """Number of packets."""
        return len(self.tables)

    def arrival_probability(self, hist: np.ndarray) -> np.ndarray:
        """``P(g_s = 1 | h_s)`` for every packet, shape of ``hist``."""
        return np.stack([tbl[hist[..., s]] for s, tbl in enumerate(self.tables)], axis=-1)

    def advance(self, hist: np.ndarray, arrived: np.ndarray) -> np.ndarray:
        """Joint history after emitting ``arrived`` (oldest bit dropped)."""
        out = np.empty_like(hist)
        for s, nu in enumerate(self.orders):
            out[..., s] = ((hist[..., s] << 1) | arrived[..., s]) & ((1 << nu) - 1)
        return out

    def pattern_probability(self, hist: np.ndarray, pattern: tuple[bool, ...]) -> np.ndarray:
        """``P(g = pattern | h)`` for a batch of joint histories ``(..., m)``."""
        p1 = self.arrival_probability(hist)
        g = np.asarray(pattern, dtype=bool)
        result: np.ndarray = np.prod(np.where(g, p1, 1.0 - p1), axis=-1)
        return result

    def per_packet_initial(self, how: str) -> list[np.ndarray]:
        """Distribution of each packet's history before ``t = 0``."""
        out = []
        for nu, pi in zip(self.orders, self.stationaries):
            if how == "stationary":
                out.append(pi)
            else:
                d = np.zeros(1 << nu)
                d[(1 << nu) - 1 if how == "all_arrived" else 0] = 1.0
                out.append(d)
        return out

    def initial_distribution(self, how: str) -> tuple[np.ndarray, np.ndarray]:
        """Joint initial histories with positive probability: ``(H, m)`` ints and ``(H,)`` weights."""
        per = [np.flatnonzero(d > 0) for d in self.per_packet_initial(how)]
        dists = self.per_packet_initial(how)
        combos = np.array(list(itertools.product(*per)), dtype=np.int64).reshape(-1, self.m)
        probs = np.ones(len(combos))
        for s, d in enumerate(dists):
            probs *= d[combos[:, s]]
        return combos, probs

    def initial_count(self, how: str) -> int:
        """Number of joint initial histories with positive probability."""
        return int(np.prod([np.count_nonzero(d > 0) for d in self.per_packet_initial(how)]))

    def sample_initial(self, how: str, size: int, rng: np.random.Generator) -> np.ndarray:
        """Draw ``size`` joint initial histories ``(size, m)``."""
        out = np.empty((size, self.m), dtype=np.int64)
        for s, d in enumerate(self.per_packet_initial(how)):
            out[:, s] = rng.choice(len(d), size=size, p=d)
        return out

    def stationary_arrival_rates(self) -> np.ndarray:
        """Long-run fraction of arrivals of each packet."""
        return np.array([float(pi @ tbl) for pi, tbl in zip(self.stationaries, self.tables)])

    def patterns(self) -> list[tuple[bool, ...]]:
        """All ``2^m`` arrival patterns, packet 0 first."""
        return [tuple(bool(b) for b in bits) for bits in itertools.product((False, True), repeat=self.m)]
