"""Benchmark: kfio's exact verdict vs the naive route.

The naive route is ``sympy.Matrix.jordan_form`` followed by a brute force
over all ``2^N`` phase subsets for the largest blind set.  It runs in a child
process with a time limit, so a case it cannot finish is reported as
``> limit`` instead of hanging the benchmark.  Both routes run in this same
process tree on the same machine, so the ratio is meaningful on a loaded
machine.

Run: ``python bench/bench_verdict.py [--naive-limit SECONDS]``.
"""

from __future__ import annotations

import argparse
import itertools
import json
import multiprocessing as mp
import random
import time

import numpy as np
import sympy

from kfio import analyze, load_request


def rot(a, b):
    """Real 2x2 block with eigenvalues a +- i b."""
    return [[a, -b], [b, a]]


def blkdiag(*blocks):
    return [[str(x) for x in row] for row in sympy.diag(*[sympy.Matrix(b) for b in blocks]).tolist()]


def obscure(A, C, seed):
    """Random unimodular similarity, so no case is handed over in Jordan form."""
    rng = random.Random(seed)
    n = len(A)
    T = sympy.eye(n)
    for _ in range(2 * n):
        i, j = rng.sample(range(n), 2)
        E = sympy.eye(n)
        E[i, j] = rng.choice([-1, 1])
        T = T * E
    A2 = T * sympy.Matrix(A) * T.inv()
    C2 = sympy.Matrix(C) * T.inv()
    return [[str(x) for x in A2.row(i)] for i in range(n)], [[str(x) for x in C2.row(i)] for i in range(C2.rows)]


def random_irreducible(n, seed):
    rng = random.Random(seed)
    while True:
        A = sympy.Matrix(n, n, lambda i, j: rng.randint(-5, 5))
        if sympy.Poly(A.charpoly().as_expr()).is_irreducible:
            return [[int(x) for x in A.row(i)] for i in range(n)], [[rng.randint(-3, 3) or 1 for _ in range(n)]]


def cases():
    bern = {"model": "bernoulli", "arrival_probability": "1/2"}
    ge = {"model": "gilbert_elliott", "failure_rate": "1/10", "recovery_rate": "3/10"}
    out = [
        ("Sinopoli et al. (2004) scalar", [["-5/4"]], [[1]], bern),
        ("Sinopoli et al. (2004) 3x3", [["5/4", 1, 0], [0, "9/10", 7], [0, 0, "3/5"]], [[1, 0, 2]], bern),
        ("Sinopoli et al. (2004)/002 2x2", [["5/4", 0], [1, "11/10"]], [[1, 1]], bern),
        ("Rohr, Marelli and Fu (2014) Ex. 1, Bernoulli", [[2, 0], [0, -2]], [[1, 1]], bern),
        ("Rohr, Marelli and Fu (2014) Ex. 2, Gilbert-Elliott", [[2, 0], [0, -2]], [[1, 1]], ge),
    ]
    A4, C4 = random_irreducible(4, 4)
    out.append(("random 4x4, irreducible quartic", A4, C4, bern))
    A8, C8 = random_irreducible(8, 8)
    out.append(("random 8x8, irreducible octic", A8, C8, bern))
    # 12x12: rotation blocks of orders 4, 3, 6 and repeated Jordan blocks, all of modulus 2 -> one FMO class
    A12 = blkdiag(
        rot(0, 2), [[-1, -3], [1, -1]], [[1, -3], [1, 1]], [[2, 1], [0, 2]], [[2, 1], [0, 2]], [[-2, 1], [0, -2]]
    )
    rng = random.Random(12)
    C12 = [[rng.randint(-2, 2) for _ in range(12)] for _ in range(2)]
    A12o, C12o = obscure(A12, C12, 12)
    out.append(("12x12 rotations + repeated Jordan", A12o, C12o, bern))
    # N = 60: 2 * blkdiag(rotation of order 3, rotation of order 4, companion of Phi_5)
    phi5 = [[0, 0, 0, -2], [2, 0, 0, -2], [0, 2, 0, -2], [0, 0, 2, -2]]  # 2 * companion(x^4+x^3+x^2+x+1)
    A60 = blkdiag([[-1, -3], [1, -1]], rot(0, 2), phi5)
    C60 = [[1, 0, 1, 0, 1, 0, 0, 0]]
    out.append(("degenerate, period 60, Bernoulli", A60, C60, bern))
    out.append(("degenerate, period 60, Gilbert-Elliott", A60, C60, ge))
    return out


def time_kfio(A, C, ch, repeat=3):
    body = json.dumps({"system": {"A": A, "C": C}, "channel": ch})
    best, rep = float("inf"), None
    for _ in range(repeat):
        t = time.perf_counter()
        rep = analyze(load_request(body))
        best = min(best, time.perf_counter() - t)
    return best, rep


def _naive(A, C, q):
    """jordan_form, then the largest blind phase set by brute force over 2^N subsets."""
    try:
        q.put(_naive_body(A, C))
    except Exception as exc:  # noqa: BLE001 - the naive route's own failure is the measurement
        q.put(f"fails: {type(exc).__name__}")


def _naive_body(A, C):
    t = time.perf_counter()
    M = sympy.Matrix([[sympy.Rational(str(x)) for x in r] for r in A])
    P, J = M.jordan_form()
    Cj = sympy.Matrix([[sympy.Rational(str(x)) for x in r] for r in C]) * P
    n = J.shape[0]
    eig = [complex(J[i, i]) for i in range(n)]
    heads = [i for i in range(n) if i == 0 or J[i - 1, i] == 0]
    mods = sorted({round(abs(eig[i]), 9) for i in heads}, reverse=True)
    Cn = np.array(Cj.evalf(30).tolist(), dtype=complex)
    worst = 0
    for m in mods:
        cols = [i for i in heads if round(abs(eig[i]), 9) == m and m >= 1]
        if not cols:
            continue
        ang = [np.angle(eig[i]) / (2 * np.pi) for i in cols]
        N = 1
        while any(abs((a * N) - round(a * N)) > 1e-9 for a in ang) and N <= 64:
            N += 1
        rows = [Cn[:, cols] * np.exp(2j * np.pi * np.array(ang) * k) for k in range(N)]
        for F in itertools.product([0, 1], repeat=N):
            S = [rows[k] for k in range(N) if F[k]]
            if S and np.linalg.matrix_rank(np.vstack(S), tol=1e-8) == len(cols):
                continue
            worst = max(worst, sum(F))
    return time.perf_counter() - t


def time_naive(A, C, limit):
    q = mp.Queue()
    p = mp.Process(target=_naive, args=(A, C, q))
    p.start()
    p.join(limit)
    if p.is_alive():
        p.kill()
        p.join()
        return None
    return q.get() if not q.empty() else None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--naive-limit", type=float, default=120.0, help="seconds before the naive route is stopped")
    args = ap.parse_args()
    print(f"{'case':42s} {'kfio':>10s} {'naive':>22s} {'ratio':>8s}  verdict")
    for name, A, C, ch in cases():
        t, rep = time_kfio(A, C, ch)
        tn = time_naive(A, C, args.naive_limit)
        if isinstance(tn, str):
            naive, ratio = tn, "-"
        elif tn is None:
            naive, ratio = f"> {args.naive_limit:.0f} s", f"> {args.naive_limit / t:.0f}x"
        else:
            naive, ratio = f"{tn * 1e3:.0f} ms", f"{tn / t:.1f}x"
        periods = ",".join(str(b.period) for b in rep.blocks if b.period)
        print(f"{name:42s} {t * 1e3:8.1f} ms {naive:>22s} {ratio:>8s}  {rep.verdict} (periods {periods})", flush=True)


if __name__ == "__main__":
    main()
