"""Traces simulated from known channels (seeded NumPy): the oracle of the trace-fit round trips."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def simulate_chain(table: Sequence[float], n: int, seed: int) -> np.ndarray:
    """``n`` arrivals of the Markov channel ``table`` (``table[h] = P(1 | h)``, history bits oldest first).

    Written independently of :mod:`kfio.fit`: the history is the number whose
    binary digits are the last ``k`` packets, oldest first (``2 h + x`` keeps
    the newest as the last digit, ``mod 2^k`` drops the oldest).
    """
    k = int(len(table)).bit_length() - 1
    rng = np.random.default_rng(seed)
    u = rng.random(n).tolist()
    t = [float(x) for x in table]
    size = 1 << k
    h = size - 1  # start from "all arrived"
    out = bytearray(n)
    for i in range(n):
        x = 1 if u[i] < t[h] else 0
        out[i] = x
        h = (2 * h + x) % size
    return np.frombuffer(bytes(out), dtype=np.uint8)
