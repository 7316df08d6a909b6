"""Benchmark of one Riccati step over a batch: achieved GFLOP/s against a flat GEMM.

    python bench/bench_kernel.py [--sizes 3,6,12,20,40] [--work 6e6] [--repeats 5] [--reference COMMIT]

For each state dimension ``n`` (one packet, ``p = 1``, and a 2-row masked packet pair at n = 3),
``M`` trajectories are chosen so that ``M * n(n+1)/2`` is about ``--work``.  Timed, in CPU seconds
(``time.process_time``, the machine is shared) per step, best of ``--repeats``, one BLAS thread
(``OPENBLAS_NUM_THREADS=1`` unless set):

* ``new``: :meth:`kfio.simulation._packed.PackedRiccatiStep.advance` (cache-sized column blocks,
  buffers reused, the step in place), the default kernel now;
* ``previous``: ``PackedRiccatiStep.apply_packed`` of the reference commit (default: main before this
  kernel), run on the same data in a child interpreter in the same run (``bench/_reference.py``);
* ``GEMM``: one flat ``(N, N) @ (N, M)`` product over the whole batch, the rate a step's arithmetic
  could run at; and the same product in the kernel's column blocks (a stricter rate at small ``n``,
  where the flat GEMM is limited by memory).

The flop count of a step is ``2 N^2`` (open loop) ``+ 2 p n N`` (``C P``) ``+ p(p+1) N``
(``C P C'``) ``+ 2 p N`` (``V'V``) ``+ 2 p^2 n`` (whitening) per trajectory.  "bound" is that count
at a GEMM rate; "x bound" is the kernel's time over it (flat GEMM, and blocked in brackets).
"""

from __future__ import annotations

import argparse
import inspect
import json
import os
import platform
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _reference import run_reference  # noqa: E402

from kfio.simulation._packed import PackedRiccatiStep  # noqa: E402

#: The reference: the packed kernel before blocking, with the filtered unpack.
PREVIOUS_COMMIT = "7299885"


def case_data(n: int, p: int, rows: int, work: float) -> tuple:
    """The batch of one case: the same in this process and (by its source) in the reference's child."""
    import numpy as np

    rng = np.random.default_rng(n)
    N = n * (n + 1) // 2
    M = max(1000, int(work / N))
    A = rng.normal(size=(n, n)) / np.sqrt(n)
    C = rng.normal(size=(p, n))
    Q, R = np.eye(n), np.eye(p)
    X = rng.normal(size=(M, n, n))
    P = np.einsum("mij,mkj->mik", X, X) / n
    mask = (rng.random((M, rows)) < 0.6).astype(float)
    return A, C, Q, R, P, mask


PREVIOUS = (
    inspect.getsource(case_data)
    + """
import json, time
from kfio.simulation._kernel import PackedRiccatiStep
out = {}
for n, p, rows in CASES:
    A, C, Q, R, P, mask = case_data(n, p, rows, WORK)
    step = PackedRiccatiStep.build(A, Q, C, R)
    h = step.pack(P)
    best = float("inf")
    for _ in range(REPEATS):
        t0 = time.process_time()
        step.apply_packed(h, mask)
        best = min(best, time.process_time() - t0)
    out[f"{n},{p},{rows}"] = best
print(json.dumps(out))
"""
)


def best(fn, repeats: int, setup=None) -> float:
    t = float("inf")
    for _ in range(repeats):
        if setup is not None:
            setup()
        t0 = time.process_time()
        fn()
        t = min(t, time.process_time() - t0)
    return t


def case(n: int, p: int, rows: int, work: float, repeats: int) -> dict:
    A, C, Q, R, P, mask = case_data(n, p, rows, work)
    M, N = len(P), n * (n + 1) // 2
    step = PackedRiccatiStep.build(A, Q, C, R)
    h0 = step.pack(P)
    h = h0.copy()
    ws = step.workspace(M)
    t_new = best(lambda: step.advance(h, mask, ws), repeats, setup=lambda: np.copyto(h, h0))
    T = step.T
    t_flat = best(lambda: T @ h0, repeats)
    out = np.empty((N, ws.B))

    def blocked() -> None:
        for a in range(0, M, ws.B):
            b = min(a + ws.B, M)
            np.matmul(T, h0[:, a:b], out=out[:, : b - a])

    t_blocked = best(blocked, repeats)
    flops = M * (2 * N * N + 2 * p * n * N + p * (p + 1) * N + 2 * p * N + 2 * p * p * n)
    gemm = 2 * N * N * M
    return {
        "n": n,
        "p": p,
        "rows": rows,
        "M": M,
        "B": ws.B,
        "new": t_new,
        "flat": gemm / t_flat,
        "blocked": gemm / t_blocked,
        "flops": flops,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="3,6,12,20,40")
    ap.add_argument("--work", type=float, default=6e6, help="M * n(n+1)/2 per case")
    ap.add_argument("--repeats", type=int, default=5, help="repeats per timing (best of)")
    ap.add_argument("--reference", default=PREVIOUS_COMMIT, help="commit of the previous kernel")
    args = ap.parse_args()
    cases = [(n, 1, 1) for n in (int(x) for x in args.sizes.split(","))] + [(3, 2, 2)]
    rows = [case(n, p, r, args.work, args.repeats) for n, p, r in cases]
    previous = run_reference(
        f"CASES = {cases!r}\nWORK = {args.work!r}\nREPEATS = {args.repeats}\n" + PREVIOUS, commit=args.reference
    )
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(
        f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
        f"NumPy {np.__version__}, OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}, load average {load:.1f}"
    )
    print(f"CPU ms per step, best of {args.repeats}; previous = PackedRiccatiStep of {args.reference}, same run\n")
    print(
        "| n | p (mask rows) | M | block | new | previous | speed-up | GEMM GFLOP/s flat (blocked) | "
        "new GFLOP/s | x bound flat (blocked) | previous x bound flat |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        t_prev = previous[f"{r['n']},{r['p']},{r['rows']}"]
        bound_flat, bound_blocked = r["flops"] / r["flat"], r["flops"] / r["blocked"]
        print(
            f"| {r['n']} | {r['p']} ({r['rows']}) | {r['M']} | {r['B']} | {r['new'] * 1e3:.1f} | {t_prev * 1e3:.1f} | "
            f"{t_prev / r['new']:.1f}x | {r['flat'] / 1e9:.2f} ({r['blocked'] / 1e9:.2f}) | "
            f"{r['flops'] / r['new'] / 1e9:.2f} | {r['new'] / bound_flat:.1f}x ({r['new'] / bound_blocked:.1f}x) | "
            f"{t_prev / bound_flat:.1f}x |"
        )
    print("\n" + json.dumps({"rows": rows, "previous": previous}))


if __name__ == "__main__":
    main()
