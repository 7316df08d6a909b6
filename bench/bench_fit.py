"""Speed of ``kfio fit`` against a naive baseline measured in the same run (a benchmark, not a test).

For traces of ``10^4 .. 10^6`` packets of a bursty Gilbert-Elliott channel:

* ``counts``: kfio's transition counts of orders 0..4 (NumPy bit shifts,
  :func:`kfio.fit.transition_counts`) against a plain Python loop that walks
  the trace once per order with a dict of histories;
* ``fit``: the whole :func:`kfio.fit.fit` (five candidates, BIC, intervals,
  run-length tests) per million packets;
* ``verdict``: :func:`kfio.fit.analyze_at_confidence` for the scalar plant
  ``A = -5/4`` (exact verdicts at the corners, and the bisection behind
  ``samples_needed``) on a near-critical Bernoulli trace.

    python bench/bench_fit.py            # prints one line per size, ratios naive / kfio
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import kfio
from kfio.fit import analyze_at_confidence, transition_counts, with_trace
from kfio.stability import analyze


def bursty(n: int, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    u = rng.random(n)
    out = np.empty(n, dtype=np.uint8)
    h = 1
    for i in range(n):
        x = 1 if u[i] < (0.95 if h else 0.3) else 0
        out[i] = x
        h = x
    return out


def naive_counts(a: list[int], order: int) -> dict[tuple[int, ...], list[int]]:
    counts: dict[tuple[int, ...], list[int]] = {}
    for t in range(order, len(a)):
        counts.setdefault(tuple(a[t - order : t]), [0, 0])[a[t]] += 1
    return counts


def best_of(fn, repeat: int = 3) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="10000,100000,1000000")
    args = parser.parse_args()
    for n in (int(s) for s in args.sizes.split(",")):
        a = bursty(n)
        listed = a.tolist()
        assert all(  # the same counts by both routes
            transition_counts(a, k)[int("".join(map(str, h)) or "0", 2)].tolist() == c
            for k in range(5)
            for h, c in naive_counts(listed, k).items()
        )
        fast = best_of(lambda a=a: [transition_counts(a, k) for k in range(5)])
        slow = best_of(lambda listed=listed: [naive_counts(listed, k) for k in range(5)], repeat=1)
        whole = best_of(lambda a=a: kfio.fit(a), repeat=1)
        print(
            f"n = {n:>8}: counts kfio {fast * 1e3:8.2f} ms, naive {slow * 1e3:9.1f} ms, ratio {slow / fast:6.1f}; "
            f"whole fit {whole * 1e3:8.1f} ms ({whole / n * 1e9:6.0f} ns/packet)"
        )
    plant = kfio.load_request(
        '{"system": {"A": [[-1.25]], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": 0.5}}'
    )
    near = (np.random.default_rng(2).random(1000) < 0.378).astype(np.uint8)
    request, found = with_trace(plant, near)
    point = analyze(request).verdict
    t = best_of(lambda: analyze_at_confidence(request, found, point))
    v = analyze_at_confidence(request, found, point)
    print(
        f"verdict at 95% for A = -5/4 on 1000 packets: {v.verdict}, samples_needed {v.samples_needed}, {t * 1e3:.1f} ms"
    )


if __name__ == "__main__":
    main()
