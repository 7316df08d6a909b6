"""Benchmark of one Riccati step over a batch (issue 15 item 1): achieved GFLOP/s against a flat GEMM.

    python bench/bench_kernel.py [--sizes 3,6,12,20,40] [--work 6e6] [--steps 5]

For each state dimension ``n`` (one packet, ``p = 1``, and a 2-row masked packet pair at n = 3),
``M`` trajectories are chosen so that ``M * n(n+1)/2`` is about ``--work``.  Timed, in CPU seconds
(``time.process_time``, the machine is shared) per step, best of ``--steps``:

* ``packed``: :class:`kfio.simulation._kernel.PackedRiccatiStep` (structure of arrays, flat GEMMs),
  the default kernel now;
* ``matrix``: :class:`kfio.simulation._kernel.RiccatiStep`, the previous default (batched matrices);
* ``GEMM``: one flat ``(N, N) @ (N, M)`` product, the rate a step's arithmetic could run at.

The flop count of a step is that of the packed algorithm: ``2 N^2`` (open loop) ``+ 2 p n N``
(``C P``) ``+ p(p+1) N`` (``C P C'``) ``+ 2 p N`` (``V'V``) ``+ 2 p^2 n`` (whitening) per trajectory.
"bound" is that count at the GEMM rate; "x bound" is the packed time over it.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from kfio.simulation._kernel import PackedRiccatiStep, RiccatiStep  # noqa: E402


def best(fn, repeats: int) -> float:
    t = float("inf")
    for _ in range(repeats):
        t0 = time.process_time()
        fn()
        t = min(t, time.process_time() - t0)
    return t


def case(n: int, p: int, rows: int, work: float, repeats: int) -> tuple:
    rng = np.random.default_rng(n)
    N = n * (n + 1) // 2
    M = max(1000, int(work / N))
    A = rng.normal(size=(n, n)) / np.sqrt(n)
    C = rng.normal(size=(p, n))
    Q, R = np.eye(n), np.eye(p)
    X = rng.normal(size=(M, n, n))
    P = np.einsum("mij,mkj->mik", X, X) / n
    mask = (rng.random((M, rows)) < 0.6).astype(float)
    packed, matrix = PackedRiccatiStep.build(A, Q, C, R), RiccatiStep.build(A, Q, C, R)
    h = packed.pack(P)
    t_packed = best(lambda: packed.apply_packed(h, mask), repeats)
    t_matrix = best(lambda: matrix.apply(P, mask), repeats)
    T = packed.T
    t_gemm = best(lambda: T @ h, repeats)
    gemm_rate = 2 * N * N * M / t_gemm
    flops = M * (2 * N * N + 2 * p * n * N + p * (p + 1) * N + 2 * p * N + 2 * p * p * n)
    bound = flops / gemm_rate
    return n, p, rows, M, t_packed, t_matrix, gemm_rate, flops / t_packed, bound


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="3,6,12,20,40")
    ap.add_argument("--work", type=float, default=6e6, help="M * n(n+1)/2 per case")
    ap.add_argument("--steps", type=int, default=5, help="repeats per timing (best of)")
    args = ap.parse_args()
    cases = [(n, 1, 1) for n in (int(x) for x in args.sizes.split(","))] + [(3, 2, 2)]
    print(
        "| n | p (mask rows) | M | packed ms/step | matrix (previous) ms/step | speed-up | GEMM GFLOP/s | "
        "packed GFLOP/s | x bound |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for n, p, rows in cases:
        n, p, rows, M, tp, tm, rate, achieved, bound = case(n, p, rows, args.work, args.steps)
        print(
            f"| {n} | {p} ({rows}) | {M} | {tp * 1e3:.1f} | {tm * 1e3:.1f} | {tm / tp:.1f}x | {rate / 1e9:.2f} | "
            f"{achieved / 1e9:.2f} | {tp / bound:.1f}x |"
        )


if __name__ == "__main__":
    main()
