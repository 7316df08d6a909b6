"""Benchmark: what a compiled kernel would buy the two-sensor front proof.

kfio has no compiled code of its own and does not depend on Numba; this script measures what
two of the blind walk's hot functions would cost compiled, so that the decision to add such a
dependency is made on numbers.  It runs ``analyze`` on the two dense sensors of period 84
(``bench_sensors.py``'s case) in this process, records the first calls of
:meth:`kfio.search._affine.Affine.lex_first_possible` and of
``kfio.search._blind_batch._real_line_residuals`` (their inputs and answers), then times the
NumPy functions against Numba versions on the same inputs (CPU seconds, the best of
``--rounds`` passes over the calls on each side):

* the lex-first test decided per flat with an early exit: only the maps ``a (n - b)`` with
  ``b`` in the flat can put a phase at 0, and a map is dropped at the first phase where its
  image and the flat differ.  Integer logic: its answers must equal NumPy's exactly, and the
  script fails if one differs;
* the one-row residuals ``|W_t - (W_t . u_e) u_e|`` in a loop per pair and slot.  Its sums run
  in another order than BLAS and ``einsum``, so the floats differ in their last bits: the
  script prints the largest difference (relative to the largest row entry) and how many
  residuals would change side at rank thresholds of 1e-10, 1e-9 and 1e-8 of that scale.

Third, ``P_hat_N`` of Rohr, Marelli and Fu (2010) for ``N = 2, 4, 8`` on Sinopoli et al.
(2004)'s 3x3 system at ``lambda = 0.4`` (``examples/bounds_seed004_3x3.json``): the three
fixed points of ``g_N`` (355 applications) by kfio's level-by-level NumPy recursion and by a
compiled loop over the same tree, with the same start, stopping rule and tolerance.  It prints
both times, the iteration counts (which must agree) and the largest relative difference of
the fixed points (the sums run in another order, so they differ in their last bits), and the
whole in-process ``bounds`` request for scale.

Needs Numba beside kfio, in a virtual environment of its own:
``python -m venv /tmp/nb && /tmp/nb/bin/pip install -e . numba`` then
``OPENBLAS_NUM_THREADS=1 /tmp/nb/bin/python bench/bench_compiled_kernels.py [--calls 300] [--whole] [--part sensors|phat|all]``.
With ``--whole`` it then runs the whole ``analyze`` four more times, alternating the NumPy
functions and both kernels in their place, and prints the CPU seconds of each run and whether
every answer's JSON is the same.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
from bench_sensors import cases

#: The request of the bounds part: Sinopoli et al. (2004)'s 3x3 system at lambda = 0.4.
EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "bounds_seed004_3x3.json"


@contextlib.contextmanager
def patched(lex, res):  # type: ignore[no-untyped-def]
    """``Affine.lex_first_possible`` and the one-row residuals replaced by ``lex`` and ``res`` for the block."""
    from kfio.search import _affine, _blind_batch

    lex_np, res_np = _affine.Affine.lex_first_possible, _blind_batch._real_line_residuals
    _affine.Affine.lex_first_possible = lex  # type: ignore[method-assign]
    _blind_batch._real_line_residuals = res
    try:
        yield
    finally:
        _affine.Affine.lex_first_possible = lex_np  # type: ignore[method-assign]
        _blind_batch._real_line_residuals = res_np


def analyze_period_84():  # type: ignore[no-untyped-def]
    """``analyze`` of ``bench_sensors.py``'s two dense sensors on period 84, in this process."""
    from kfio import analyze, load_request
    from kfio._budget import Budget
    from kfio.model._limits import DEFAULT_LIMITS

    body = dict(cases())["period 84, random dense rows"]
    return analyze(load_request(body, DEFAULT_LIMITS.for_command("analyze")), budget=Budget(seconds=600))


def record(calls: int) -> tuple[tuple[int, tuple[int, ...]], list, list]:
    """Run the period-84 case once, keeping the first ``calls`` inputs and answers of both functions."""
    from kfio.search import _affine, _blind_batch

    lex: list = []
    res: list = []
    group: list[tuple[int, tuple[int, ...]]] = []
    lex_np = _affine.Affine.lex_first_possible
    res_np = _blind_batch._real_line_residuals

    def lex_hook(self, masks, cores):  # type: ignore[no-untyped-def]
        out = lex_np(self, masks, cores)
        if not group:
            group.append((self.n_phases, self.units))
        if len(lex) < calls:
            lex.append((masks.copy(), cores.copy(), out.copy()))
        return out

    def res_hook(rows, e):  # type: ignore[no-untyped-def]
        out = res_np(rows, e)
        if len(res) < calls:
            res.append((rows.copy(), e.copy(), out.copy()))
        return out

    with patched(lex_hook, res_hook):
        analyze_period_84()
    return group[0], lex, res


def whole(lex_nb, res_nb, inverses, rounds: int) -> None:  # type: ignore[no-untyped-def]
    """``analyze`` of the period-84 case with the NumPy functions and with the kernels in their place, alternating."""
    from kfio.search import _affine, _blind_batch

    def lex_compiled(self, masks, cores):  # type: ignore[no-untyped-def]
        return lex_nb(masks, cores, inverses, self.n_phases, self.prefix)

    sides = {
        "NumPy": (_affine.Affine.lex_first_possible, _blind_batch._real_line_residuals),
        "compiled": (lex_compiled, res_nb),
    }
    answers: set[str] = set()
    times: dict[str, list[float]] = {name: [] for name in sides}
    for _ in range(rounds):
        for name, (lex, res) in sides.items():
            with patched(lex, res):
                t = time.process_time()
                report = analyze_period_84()
                times[name].append(time.process_time() - t)
            answers.add(json.dumps(report.to_dict(), sort_keys=True))
    for name, ts in times.items():
        print(f"analyze, period 84, {name}: {' / '.join(f'{t:.1f}' for t in ts)} s CPU (alternating)")
    print(f"  same JSON: {len(answers) == 1}")


def compiled(numba):  # type: ignore[no-untyped-def]
    """The two kernels, compiled by Numba."""

    @numba.njit(cache=False)
    def lex_first(masks, cores, inverses, N0, P):  # type: ignore[no-untyped-def]
        out = np.ones(masks.shape[0], dtype=np.bool_)
        for c in range(masks.shape[0]):
            Q = masks[c]
            last = min(cores[c], P - 1)
            if not Q[0]:  # any map sending a phase of Q to 0 comes first
                out[c] = not Q.any()
                continue
            done = False
            for b in range(N0):
                if not Q[b]:
                    continue  # the image lacks phase 0: it comes after Q
                for ai in inverses:  # g(n) = a (n - b): phase t of g(Q) is n = a^{-1} t + b
                    for t in range(1, last + 1):
                        g = Q[(ai * t + b) % N0]
                        if g != Q[t]:
                            done = g
                            break
                    if done:
                        break
                if done:
                    break
            out[c] = not done
        return out

    @numba.njit(cache=False)
    def line_residuals(rows, e):  # type: ignore[no-untyped-def]
        C, S, d = rows.shape
        out = np.empty((C, S))
        u = np.empty(d)
        for c in range(C):
            s = 0.0
            for k in range(d):
                s += rows[c, e[c], k] * rows[c, e[c], k]
            size = math.sqrt(s)
            for k in range(d):
                u[k] = rows[c, e[c], k] / size
            for t in range(S):
                coef = 0.0
                for k in range(d):
                    coef += rows[c, t, k] * u[k]
                acc = 0.0
                for k in range(d):
                    x = rows[c, t, k] - coef * u[k]
                    acc += x * x
                out[c, t] = math.sqrt(acc)
        return out

    return lex_first, line_residuals


def timed(fn, calls: list, rounds: int) -> float:  # type: ignore[no-untyped-def]
    best = math.inf
    for _ in range(rounds):
        t = time.process_time()
        for args in calls:
            fn(*args)
        best = min(best, time.process_time() - t)
    return best


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--calls", type=int, default=300, help="calls of each function recorded (memory grows with it)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--whole", action="store_true", help="also time the whole analyze with the kernels in place")
    ap.add_argument("--part", choices=("sensors", "phat", "all"), default="all")
    args = ap.parse_args()
    try:
        import numba
    except ImportError:
        print("needs Numba beside kfio (not a kfio dependency): see this script's docstring", file=sys.stderr)
        sys.exit(2)
    print(f"Numba {numba.__version__}, NumPy {np.__version__}, CPU seconds, best of {args.rounds} rounds")
    if args.part in ("sensors", "all"):
        sensors(args, numba)
    if args.part in ("phat", "all"):
        phat(numba, args.rounds)


def sensors(args: argparse.Namespace, numba) -> None:  # type: ignore[no-untyped-def]
    """The two kernels of the front proof on recorded period-84 calls (and, with ``--whole``, the whole run)."""
    from kfio.search._affine import Affine
    from kfio.search._blind_batch import _real_line_residuals

    (N0, units), lex, res = record(args.calls)
    affine = Affine(N0, units)
    inverses = np.array([pow(a, -1, N0) for a in units], dtype=np.int64)
    lex_nb, res_nb = compiled(numba)
    t = time.process_time()
    lex_nb(lex[0][0], lex[0][1], inverses, N0, affine.prefix)
    res_nb(res[0][0], res[0][1])
    print(f"compile of both kernels: {time.process_time() - t:.2f} s CPU")
    for masks, cores, want in lex:
        if not np.array_equal(lex_nb(masks, cores, inverses, N0, affine.prefix), want):
            sys.exit("the compiled lex-first test disagrees with NumPy's")
    worst, flips = 0.0, 0
    for rows, e, want in res:
        got = res_nb(rows, e)
        scale = float(np.abs(rows).max())
        worst = max(worst, float(np.abs(got - want).max()) / scale)
        flips += sum(int(((got <= tol * scale) != (want <= tol * scale)).sum()) for tol in (1e-10, 1e-9, 1e-8))
    n_lex = sum(m.shape[0] for m, _, _ in lex)
    n_res = sum(r.shape[0] for r, _, _ in res)
    t_np = timed(lambda m, c, _: affine.lex_first_possible(m, c), lex, args.rounds)
    t_nb = timed(lambda m, c, _: lex_nb(m, c, inverses, N0, affine.prefix), lex, args.rounds)
    print(f"lex-first, {len(lex)} calls, {n_lex} flats: NumPy {t_np:.3f} s, Numba {t_nb:.3f} s, {t_np / t_nb:.1f}x;")
    print("  answers identical")
    t_np = timed(lambda r, e, _: _real_line_residuals(r, e), res, args.rounds)
    t_nb = timed(lambda r, e, _: res_nb(r, e), res, args.rounds)
    print(f"residuals, {len(res)} calls, {n_res} pairs: NumPy {t_np:.3f} s, Numba {t_nb:.3f} s, {t_np / t_nb:.1f}x;")
    print(f"  largest difference {worst:.1e} of the largest entry, {flips} residuals change side at 1e-10..1e-8")
    if args.whole:
        del lex, res
        whole(lex_nb, res_nb, inverses, min(args.rounds, 2))


def phat(numba, rounds: int) -> None:  # type: ignore[no-untyped-def]
    """``P_hat_2, P_hat_4, P_hat_8`` of the 3x3 seed system: the NumPy fixed points against a compiled ``g_N``."""
    from kfio import bounds, load_request
    from kfio.riccati_bounds import _phat
    from kfio.riccati_bounds._vech import vech

    text = EXAMPLE.read_text()
    example = json.loads(text)
    A, C, Q, R = (np.array(example["system"][k], dtype=float) for k in ("A", "C", "Q", "R"))
    lam = float(example["channel"]["arrival_probability"])
    op = _phat.BatchedMare(A, C, Q, R, lam)
    start = vech(_phat.p_hat_sequence(A, C, Q, R, lam, [1])[1].matrix)

    @numba.njit(cache=False)
    def g_n(h, N, AXA, AXC, CXC, q, r, iu, ju, leaves):  # type: ignore[no-untyped-def]
        # Level k holds phi(X, S) for the 2^k prefixes S (lost first, then arrived), as vech rows.
        m, n = h.shape[0], AXC.shape[1]
        level = np.empty((1, m))
        level[0] = h
        gain = np.empty(n)
        for _ in range(N):
            b = level.shape[0]
            nxt = np.empty((2 * b, m))
            for i in range(b):
                x = level[i]
                for j in range(m):  # Phi_0 = A X A' + Q
                    s = 0.0
                    for k in range(m):
                        s += x[k] * AXA[k, j]
                    nxt[i, j] = s + q[j]
                s = r
                for k in range(m):
                    s += x[k] * CXC[k]
                s = math.sqrt(s)
                for a in range(n):  # A X C' / sqrt(C X C' + R)
                    t = 0.0
                    for k in range(m):
                        t += x[k] * AXC[k, a]
                    gain[a] = t / s
                for j in range(m):  # Phi_1 = Phi_0 - A X C' (C X C' + R)^-1 C X A'
                    nxt[b + i, j] = nxt[i, j] - gain[iu[j]] * gain[ju[j]]
            level = nxt
        out = np.zeros(m)
        for i in range(level.shape[0]):
            for j in range(m):
                out[j] += leaves[i] * level[i, j]
        return out

    def leaves(N: int) -> np.ndarray:
        """``P(S)`` of the ``2^N`` arrival sequences, in the order of the last level (from the tree's own weights)."""
        w = op._tree_weights(N)[-1]
        return np.concatenate([w * (1.0 - lam), w * lam])

    class Compiled:
        """What :func:`_phat._fixed_point` asks of a ``BatchedMare``, with the compiled ``g_N``."""

        n, _q = op.n, op._q
        weights = {N: leaves(N) for N in (2, 4, 8)}
        matrices = (op._AXA, op._AXC, op._CXC[:, 0], op._q, float(op._r[0]), op._iu, op._ju)

        def g_n(self, h: np.ndarray, N: int) -> np.ndarray:
            return g_n(h, N, *self.matrices, self.weights[N])

    def chain(mare) -> dict[int, _phat.PHat]:  # type: ignore[no-untyped-def]
        """``P_hat_2, _4, _8`` by :func:`_phat._fixed_point`, each started at ``P_hat_d`` as ``p_hat_sequence`` does."""
        out, h = {}, start
        for N, d in ((2, 1), (4, 2), (8, 4)):  # d: the largest proper divisor of N
            out[N] = _phat._fixed_point(mare, N, h, d, 1e-11, 20_000, None)
            h = vech(out[N].matrix)
        return out

    compiled = Compiled()
    t = time.process_time()
    chain(compiled)
    print(f"compile of g_N: {time.process_time() - t:.2f} s CPU")
    t_np, t_nb = math.inf, math.inf
    for _ in range(rounds):
        t = time.process_time()
        want = chain(op)
        t_np = min(t_np, time.process_time() - t)
        t = time.process_time()
        got = chain(compiled)
        t_nb = min(t_nb, time.process_time() - t)
    print(f"P_hat_2, _4, _8 of the 3x3 seed system: NumPy {1000 * t_np:.1f} ms, Numba {1000 * t_nb:.2f} ms, ", end="")
    print(f"{t_np / t_nb:.1f}x")
    for N in (2, 4, 8):
        M = want[N].matrix
        diff = float(np.abs(got[N].matrix - M).max() / np.abs(M).max())
        print(
            f"  N = {N}: iterations {got[N].iterations} (NumPy {want[N].iterations}), largest relative difference {diff:.1e}"
        )
    request = load_request(text)
    times = []
    for _ in range(20):
        t = time.process_time()
        bounds(request)
        times.append(time.process_time() - t)
    print(f"  the whole bounds request in process (NumPy): median {1000 * sorted(times)[10]:.1f} ms of 20")


if __name__ == "__main__":
    main()
