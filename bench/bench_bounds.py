"""Benchmark of ``kfio bounds``, each measurement against a naive baseline run in the same process.

    python bench/bench_bounds.py [--systems 6] [--repeats 3] [--seed 0] [--sizes 10,20,40] [--reference-max-n 20]

0. ``lambda_upper`` to 1e-6 for random systems of n = 10, 20, 40 (targets: n = 20 under 5 s, n = 40
   under 60 s): the solver-free route (annihilating / MARE gains, continuation, exact certificates)
   against the previous code (main at ``736f7c6``: bisection over LMI solves, run in a subprocess by
   ``bench/_reference.py``), CPU seconds (``time.process_time``) since the machine is shared.
1. ``lambda_upper`` to 1e-6 for random n = 10 systems by the LMI route alone (``lmi="always"``),
   against re-building the CVXPY problem at every bisection step (same algorithm, same answers).
2. ``P_hat_20`` for Sinopoli et al. (2004)'s 3x3 system at lambda = 0.4 (target < 30 s), against the
   per-sequence recursion of Rohr, Marelli and Fu (2010) eq. 4 (one ``g_N`` at N = 12 is timed both ways; the
   naive ``P_hat_20`` time is extrapolated from it, since running it would take hours).
3. A 21 x 21 region map for a two-sensor, n = 2 system (target < 60 s), against labelling every
   cell independently with a freshly built LMI.
"""

from __future__ import annotations

import argparse
import itertools
import sys
import time
from fractions import Fraction
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from kfio.riccati_bounds import _lmi  # noqa: E402
from kfio.riccati_bounds import _riccati as riccati  # noqa: E402
from kfio.riccati_bounds._certificate import ExactPlant  # noqa: E402
from kfio.riccati_bounds._compute import critical_lower_bound  # noqa: E402
from kfio.riccati_bounds._lmi import StabilityLMI  # noqa: E402
from kfio.riccati_bounds._phat import BatchedMare, p_hat_sequence  # noqa: E402
from kfio.riccati_bounds._search import CertifiedSearch  # noqa: E402
from kfio.riccati_bounds._vech import vech  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _reference import REFERENCE_COMMIT, run_reference  # noqa: E402

REFERENCE_LAMBDA_UPPER = """
import json, time
from fractions import Fraction
import numpy as np
from kfio.riccati_bounds._certificate import ExactPlant
from kfio.riccati_bounds._search import CertifiedSearch
A, C, lower = np.array({A}), np.array({C}), {lower}
ex = lambda M: tuple(tuple(Fraction(float(x)) for x in r) for r in M)
t = time.process_time()
ub = CertifiedSearch(A, C, [list(range(C.shape[0]))], ExactPlant(ex(A), (ex(C),))).bisect([Fraction(1)], 0, lower, 1e-6)
print(json.dumps({{"cpu": time.process_time() - t, "value": float(ub.value), "solves": ub.steps}}))
"""


class RebuildingSearch(CertifiedSearch):
    """The naive baseline: a new CVXPY problem (and compilation) for every LMI solve."""

    def certify_lmi(self, lambdas):
        _lmi._CACHE.clear()  # the compiled problem is kept per shape otherwise
        self.lmi = StabilityLMI(self.A.shape[0], self.lmi.pattern_rows)
        return super().certify_lmi(lambdas)


def exact(M: np.ndarray) -> tuple[tuple[Fraction, ...], ...]:
    return tuple(tuple(Fraction(float(x)) for x in row) for row in M)


def random_system(rng: np.random.Generator, n: int = 10, p: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Entries rounded to 3 decimals (so the exact plant is short), spectral radius about 1.2."""
    A = rng.normal(size=(n, n))
    A = np.round(A * 1.2 / max(abs(np.linalg.eigvals(A))), 3)
    return A, np.round(rng.normal(size=(p, n)), 3)


def bench_sizes(sizes: list[int], count: int, seed: int, reference_max_n: int) -> list[tuple]:
    rows = []
    for n in sizes:
        rng = np.random.default_rng(seed)
        for k in range(count):
            A, C = random_system(rng, n)
            plant = ExactPlant(exact(A), (exact(C),))
            lower = critical_lower_bound(riccati.spectral_radius(A))
            search = CertifiedSearch(A, C, [[0, 1]], plant)
            t0 = time.process_time()
            ub = search.bisect([Fraction(1)], 0, lower, 1e-6)
            t_new = time.process_time() - t0
            ref = None
            if n <= reference_max_n:
                ref = run_reference(REFERENCE_LAMBDA_UPPER.format(A=A.tolist(), C=C.tolist(), lower=lower))
            route = ", ".join(f"{r} x{c}" for r, c in search.routes.items())
            rows.append((n, k, lower, float(ub.value), ub.steps, route, t_new, ref))
    return rows


def bench_lambda_upper(count: int, seed: int, repeats: int) -> list[tuple]:
    rng = np.random.default_rng(seed)
    rows = []
    for k in range(count):
        A, C = random_system(rng)
        plant = ExactPlant(exact(A), (exact(C),))
        lower = critical_lower_bound(riccati.spectral_radius(A))
        best: dict[type, tuple] = {}
        for _ in range(repeats):  # interleaved, best of `repeats`: the machine is shared
            for cls in (CertifiedSearch, RebuildingSearch):
                t0 = time.perf_counter()
                ub = cls(A, C, [[0, 1]], plant, lmi="always").bisect([Fraction(1)], 0, lower, 1e-6)
                t = time.perf_counter() - t0
                if cls not in best or t < best[cls][0]:
                    best[cls] = (t, ub)
        (t_fast, ub_fast), (t_slow, ub_slow) = best[CertifiedSearch], best[RebuildingSearch]
        assert ub_fast.value == ub_slow.value
        rows.append((k, lower, float(ub_fast.value), ub_fast.steps, ub_fast.certificate.method, t_fast, t_slow))
    return rows


def g_n_by_recursion(X, A, C, Q, R, lam, N):
    total = np.zeros_like(X)
    for seq in itertools.product((0, 1), repeat=N):
        P, prob = X, 1.0
        for g in seq:
            prob *= lam if g else 1 - lam
            P = riccati.g_lambda(P, A, C, Q, R, float(g))
        total += prob * P
    return total


def bench_p_hat() -> dict:
    A = np.array([[1.25, 1, 0], [0, 0.9, 7], [0, 0, 0.6]])
    C, Q, R, lam = np.array([[1.0, 0, 2]]), 20 * np.eye(3), np.array([[2.5]]), 0.4
    t0 = time.perf_counter()
    seq = p_hat_sequence(A, C, Q, R, lam, [1, 2, 4, 8, 16, 20])
    t_seq = time.perf_counter() - t0
    t0 = time.perf_counter()
    only20 = p_hat_sequence(A, C, Q, R, lam, [20])
    t_20 = time.perf_counter() - t0
    applications = sum(e.iterations for e in only20.values())
    X = seq[1].matrix
    op = BatchedMare(A, C, Q, R, lam)
    N = 12
    t_fast = float("inf")
    for _ in range(5):  # best of 5: one call is a few ms and the machine is shared
        t0 = time.perf_counter()
        fast = op.g_n(vech(X), N)
        t_fast = min(t_fast, time.perf_counter() - t0)
    t0 = time.perf_counter()
    slow = g_n_by_recursion(X, A, C, Q, R, lam, N)
    t_slow = time.perf_counter() - t0
    assert np.allclose(fast, vech(slow), rtol=1e-10)
    work20 = sum(e.iterations * (1 << e.N) for e in only20.values())  # g_N applications weighted by 2^N
    return {
        "traces": {N: float(np.trace(e.matrix)) for N, e in sorted(seq.items())},
        "t_sequence": t_seq,
        "t_p20": t_20,
        "applications": applications,
        "t_gN_fast": t_fast,
        "t_gN_slow": t_slow,
        "naive_p20_estimate": t_slow / (1 << N) * work20 * 20 / N,
    }


def bench_region() -> dict:
    A = np.array([[1.25, 0], [1, 1.1]])
    C = np.array([[1.0, 0], [1, 1]])
    groups = [[0], [1]]
    rows = riccati.subset_rows(groups)
    plant = ExactPlant(exact(A), tuple(tuple(exact(C)[r] for r in rs) for rs in rows))
    rho2 = riccati.spectral_radius(A) ** 2
    K = 21
    values = tuple(Fraction(i, K - 1) for i in range(K))
    unstable = np.array([[float((1 - a) * (1 - b)) * rho2 >= 1 for b in values] for a in values])
    t0 = time.perf_counter()
    search = CertifiedSearch(A, C, groups, plant, lmi="always")
    labels, certified = search.region(values, unstable)
    t_fast = time.perf_counter() - t0
    t0 = time.perf_counter()
    naive = RebuildingSearch(A, C, groups, plant, lmi="always")
    naive_labels = [
        [
            "unstable" if unstable[i, j] else ("stable" if naive.certify_lmi([a, b]) is not None else "undecided")
            for j, b in enumerate(values)
        ]
        for i, a in enumerate(values)
    ]
    t_slow = time.perf_counter() - t0
    assert naive_labels == labels, "the monotone shortcut must not change a label"
    return {"t_fast": t_fast, "solves_fast": search.solves, "t_slow": t_slow, "solves_slow": naive.solves}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--systems", type=int, default=6)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sizes", default="10,20,40", help="state dimensions of section 0")
    ap.add_argument("--size-systems", type=int, default=3, help="systems per size in section 0")
    ap.add_argument("--reference-max-n", type=int, default=20, help="largest n run with the previous code")
    ap.add_argument("--sections", default="0123", help="which sections to run, e.g. 0 or 123")
    args = ap.parse_args()

    if "0" in args.sections:
        section0(args)
    if "1" in args.sections:
        section1(args)
    if "2" in args.sections:
        section2()
    if "3" in args.sections:
        section3()


def section0(args) -> None:
    print(f"0. lambda_upper to 1e-6, random systems (p = 2), CPU s; reference: main at {REFERENCE_COMMIT}")
    print(
        "    n  sys  lambda_lower  lambda_upper  reference     LMI solves  route                     new      "
        "reference  ratio"
    )
    sizes = [int(x) for x in args.sizes.split(",") if x]
    for n, k, lo, up, steps, route, t, ref in bench_sizes(sizes, args.size_systems, args.seed, args.reference_max_n):
        r_up = f"{ref['value']:.7f}" if ref else "not run"
        r_t = f"{ref['cpu']:8.2f} s" if ref else "         -"
        ratio = f"{ref['cpu'] / t:6.1f}x" if ref else "      -"
        print(
            f"   {n:2d}  {k:3d}  {lo:12.6f}  {up:12.7f}  {r_up:12s}  {steps:10d}  {route[:24]:24s}  {t:6.2f} s  "
            f"{r_t}  {ratio}"
        )
    print()


def section1(args) -> None:
    print("1. lambda_upper to 1e-6, random n = 10, p = 2 (one packet)")
    print("   sys  lambda_lower  lambda_upper  solves  certificate     parametrized  rebuilt  ratio")
    for k, lo, up, steps, method, tf, ts in bench_lambda_upper(args.systems, args.seed, args.repeats):
        print(
            f"   {k:3d}  {lo:12.6f}  {up:12.6f}  {steps:6d}  {method:14s}  {tf:10.2f} s  {ts:5.2f} s  {ts / tf:4.2f}x"
        )


def section2() -> None:
    print("\n2. P_hat_N, Sinopoli et al. (2004)'s 3x3 system, lambda = 0.4")
    r = bench_p_hat()
    print("   traces: " + ", ".join(f"N={N}: {t:.6g}" for N, t in r["traces"].items()))
    print(
        f"   P_hat_1..P_hat_20 sequence: {r['t_sequence']:.2f} s; P_hat_20 alone: {r['t_p20']:.2f} s "
        f"({r['applications']} applications of g_N along 20 <- 10 <- 5 <- 1)"
    )
    print(
        f"   one g_12: batched {r['t_gN_fast'] * 1e3:.1f} ms, per-sequence recursion {r['t_gN_slow']:.2f} s "
        f"({r['t_gN_slow'] / r['t_gN_fast']:.0f}x); naive P_hat_20 extrapolated: {r['naive_p20_estimate'] / 3600:.1f} h"
    )


def section3() -> None:
    print("\n3. 21 x 21 region map, two sensors, n = 2 (Liu and Goldsmith (2004) Fig. 5 system)")
    r = bench_region()
    print(f"   monotone search, one parametrized LMI: {r['t_fast']:.2f} s ({r['solves_fast']} solves)")
    print(
        f"   every cell, rebuilt LMI:               {r['t_slow']:.2f} s ({r['solves_slow']} solves)  "
        f"ratio {r['t_slow'] / r['t_fast']:.1f}x, same labels"
    )


if __name__ == "__main__":
    main()
