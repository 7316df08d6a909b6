"""Benchmark of ``kfio simulate``.  A script, not a test: ``python bench/bench_simulate.py``.

1. The target: 10^5 trajectories x 200 steps of Sinopoli et al. (2004)'s 3x3 system (A = [[1.25,1,0],[0,0.9,7],
   [0,0,0.6]], C = [1 0 2], Q = 20 I, R = 2.5, Bernoulli lambda = 0.6) in under 10 s, vectorized.
2. The same recursion as a per-trajectory Python loop (textbook formula, NumPy 3x3 operations), run on
   a subset of trajectories and *extrapolated* linearly to 10^5 (the loop's cost is linear in the
   number of trajectories).
3. Masking versus grouping by arrival pattern for a two-packet channel.
4. The exact enumeration of E[P_t] over 2^20 arrival sequences.

``--end-to-end`` runs instead the end-to-end target: ``simulate`` in process, 10^5 trajectories x 9 steps of the
same system, everything the report holds (per-step means, bands and percentiles of the predictor and the filtered
covariance, the final quantiles and tail exponent, the exact verdict beside them), against the **flat-GEMM bound**:
the step's flop count (``bench/bench_kernel.py``: ``2 N^2 + 2 p n N + p(p+1) N + 2 p N + 2 p^2 n`` per
trajectory, ``N = n(n+1)/2``) times ``M T``, at the rate of one flat ``(N, N) @ (N, M')`` GEMM measured in the
same run.  Two rates are given: ``M' N = 6e6`` as in ``bench_kernel.py`` (a batch larger than the caches, the
rate the kernel's bound was stated at), and ``M' = M`` (this batch, 4.8 MB, which fits in the last-level cache:
a stricter bound).  The same requests run with the code of ``--reference`` (default: main before this work) in a
child interpreter, in the same run, and the JSON of every report (a few more requests: a diverging plant, two
packets, n = 6) is hashed on both codes: they must be identical.

Times are CPU seconds (``time.process_time``; the machine is shared), one BLAS thread
(``OPENBLAS_NUM_THREADS=1`` unless set).  Row 1 is also run with the previous code (main at
``PREVIOUS_COMMIT``, before the blocked kernel) in a child interpreter in the same run
(``bench/_reference.py``).

Prints a Markdown table (pasted into docs/simulation.md).
"""

from __future__ import annotations

import argparse
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

from kfio import load_request  # noqa: E402
from kfio.simulation._finite_horizon import expected_covariance  # noqa: E402
from kfio.simulation._kernel import GroupedRiccatiStep, RiccatiStep  # noqa: E402
from kfio.simulation._setup import SimulationLimits, parse_options, sim_system  # noqa: E402
from kfio.simulation._simulate import run_monte_carlo, simulate  # noqa: E402

SEED004 = {
    "A": [[1.25, 1, 0], [0, 0.9, 7], [0, 0, 0.6]],
    "C": [[1, 0, 2]],
    "Q": [[20, 0, 0], [0, 20, 0], [0, 0, 20]],
    "R": [[2.5]],
}
TWO_PACKETS = {
    "A": [[1.25, 0], [1, 1.1]],
    "C": [[1, 0], [1, 1]],
    "Q": [[20, 0], [0, 20]],
    "R": [[2.5, 0], [0, 2.5]],
    "sensors": [{"name": "s1", "rows": [0]}, {"name": "s2", "rows": [1]}],
}
BIG = SimulationLimits(max_trajectory_steps=10**8, max_batch_floats=10**8)
#: main before the blocked kernel.
PREVIOUS_COMMIT = "7299885"
PREVIOUS = """
import json, time
from kfio import load_request
from kfio.simulation._setup import SimulationLimits
from kfio.simulation._simulate import simulate
req = load_request(BODY)
big = SimulationLimits(max_trajectory_steps=10**8, max_batch_floats=10**8)
best = float("inf")
for _ in range(REPEATS):
    t0 = time.process_time()
    simulate(req, limits=big)
    best = min(best, time.process_time() - t0)
print(json.dumps({"cpu": best}))
"""


def body(system: dict, channel: dict, steps: int, trajectories: int, seed: int = 0) -> str:
    return json.dumps(
        {
            "system": system,
            "channel": channel,
            "options": {"simulate": {"steps": steps, "trajectories": trajectories, "seed": seed}},
        }
    )


def request(system: dict, channel: dict, steps: int, trajectories: int, seed: int = 0):
    return load_request(body(system, channel, steps, trajectories, seed))


def timed(fn, repeats: int) -> tuple[float, object]:
    best, out = float("inf"), None
    for _ in range(repeats):
        t0 = time.process_time()
        out = fn()
        best = min(best, time.process_time() - t0)
    return best, out


def python_loop(A, C, Q, R, lam: float, P0, trajectories: int, steps: int, seed: int) -> np.ndarray:
    """The per-trajectory reference: one 3x3 filter at a time, textbook Riccati step."""
    rng = np.random.default_rng(seed)
    traces = np.empty((trajectories, steps + 1))
    for m in range(trajectories):
        P = P0.copy()
        traces[m, 0] = np.trace(P)
        for t in range(steps):
            APA = A @ P @ A.T + Q
            if rng.random() < lam:
                APC = A @ P @ C.T
                P = APA - APC @ np.linalg.solve(C @ P @ C.T + R, APC.T)
            else:
                P = APA
            traces[m, t + 1] = np.trace(P)
    return traces


#: The reference: statistics without the in-place route (per-step percentiles on fresh copies, unpacked final batches).
E2E_REFERENCE = "4d603a0"
E2E_TIMED = """
import hashlib, json, time
from kfio import load_request
from kfio.simulation._setup import parse_options, sim_system
from kfio.simulation._simulate import run_monte_carlo, simulate
out = {"cpu": {}, "hash": {}}
for name, text in BODIES.items():
    req = load_request(text)
    rep = simulate(req)
    out["hash"][name] = hashlib.sha256(rep.to_json().encode()).hexdigest()[:16]
    if name in TIMED:
        sim, opts = sim_system(req), parse_options(req)
        for what, fn in (("simulate", lambda: simulate(req)), ("run_monte_carlo", lambda: run_monte_carlo(sim, opts))):
            best = float("inf")
            for _ in range(REPEATS):
                t0 = time.process_time()
                fn()
                best = min(best, time.process_time() - t0)
            out["cpu"][f"{name}/{what}"] = best
print(json.dumps(out))
"""


def end_to_end(repeats: int, reference: str, rounds: int = 3) -> None:
    """The issue-25 target: ``simulate`` of 10^5 x 9 (n = 3) against the flat-GEMM bound, now and at ``reference``."""
    bernoulli = {"model": "bernoulli", "arrival_probability": 0.6}
    two = {
        "model": "per_sensor",
        "channels": {
            "s1": {"model": "bernoulli", "arrival_probability": 0.5},
            "s2": {"model": "gilbert_elliott", "failure_rate": 0.2, "recovery_rate": 0.4},
        },
    }
    rng = np.random.default_rng(6)
    six = {
        "A": (np.round(rng.normal(size=(6, 6)) / 2, 2)).tolist(),
        "C": [[1, 0, 0, 0, 0, 1]],
        "Q": np.eye(6).astype(int).tolist(),
        "R": [[1]],
    }
    bodies = {
        "target": body(SEED004, bernoulli, 9, 100_000),
        "diverging": body(
            {"A": [[2]], "C": [[1]], "Q": [[1]], "R": [[1]]},  # 10% of the trajectories diverge by t = 60
            {"model": "bernoulli", "arrival_probability": 0.2},
            60,
            2000,
        ),
        "two packets": body(TWO_PACKETS, two, 50, 10_000, seed=3),
        "n = 6": body(six, {"model": "gilbert_elliott", "failure_rate": 0.3, "recovery_rate": 0.6}, 40, 20_000, seed=5),
    }
    timed_names = ["target"]
    code = f"BODIES = {bodies!r}\nTIMED = {timed_names!r}\nREPEATS = {repeats}\n" + E2E_TIMED
    now: dict = {"cpu": {}}
    ref: dict = {"cpu": {}}
    for _ in range(rounds):  # the two codes take turns, so that a change of load hits both
        for acc, run in ((now, lambda: run_in_process(code)), (ref, lambda: run_reference(code, commit=reference))):
            out = run()
            acc["hash"] = out["hash"]
            for key, t in out["cpu"].items():
                acc["cpu"][key] = min(t, acc["cpu"].get(key, float("inf")))

    n, p, M, T = 3, 1, 100_000, 9
    N = n * (n + 1) // 2
    flops = M * T * (2 * N * N + 2 * p * n * N + p * (p + 1) * N + 2 * p * N + 2 * p * p * n)
    Tm = np.random.default_rng(0).normal(size=(N, N))
    rates = {}
    for label, cols in (("bench_kernel's batch, M' N = 6e6", int(6e6 / N)), ("this batch, M' = 10^5", M)):
        h = np.random.default_rng(1).random((N, cols))
        t, _ = timed(lambda h=h: Tm @ h, 2 * repeats + 5)
        rates[label] = 2 * N * N * cols / t
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(
        f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, NumPy {np.__version__}, "
        f"OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}, load average {load:.1f}"
    )
    print(
        f"simulate, n = 3, {M} trajectories x {T} steps, in process; CPU ms, best of {rounds} x {repeats}; reference {reference}\n"
    )
    print("| flat-GEMM rate | GFLOP/s | bound (ms) |")
    print("|---|---|---|")
    for label, r in rates.items():
        print(f"| {label} | {r / 1e9:.2f} | {flops / r * 1e3:.1f} |")
    print("\n| what | now (ms) | reference (ms) | reference / now | now x bound | reference x bound |")
    print("|---|---|---|---|---|---|")
    for what in ("simulate", "run_monte_carlo"):
        key = f"target/{what}"
        a, b = now["cpu"][key], ref["cpu"][key]
        xs = " / ".join(f"{a * r / flops:.1f}x" for r in rates.values())
        xr = " / ".join(f"{b * r / flops:.1f}x" for r in rates.values())
        print(f"| `{what}` | {a * 1e3:.1f} | {b * 1e3:.1f} | {b / a:.2f}x | {xs} | {xr} |")
    print("\n(x bound: against the first rate / the second)\n")
    for name in bodies:
        same = now["hash"][name] == ref["hash"][name]
        print(
            f"report JSON, {name}: now {now['hash'][name]}, reference {ref['hash'][name]}: {'same' if same else 'DIFFERENT'}"
        )


def run_in_process(code: str) -> dict:
    """``code`` (which prints one JSON line) run against this checkout, in a child like the reference's."""
    import subprocess

    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--end-to-end", action="store_true", help="only the issue-25 target against the flat-GEMM bound")
    ap.add_argument("--reference", default=E2E_REFERENCE, help="commit of the reference for --end-to-end")
    ap.add_argument("--trajectories", type=int, default=100_000)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--loop-trajectories", type=int, default=300, help="subset run by the Python loop")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    if args.end_to_end:
        end_to_end(args.repeats if args.repeats != 3 else 7, args.reference)
        return
    M, T = args.trajectories, args.steps
    rows = []

    req = request(SEED004, {"model": "bernoulli", "arrival_probability": 0.6}, T, M)
    t_vec, rep = timed(lambda: simulate(req, limits=BIG), args.repeats)
    rows.append((f"vectorized `simulate`, n = 3, {M} x {T}", f"{t_vec:.2f} s", f"{t_vec / (M * T) * 1e9:.0f} ns"))
    target = body(SEED004, {"model": "bernoulli", "arrival_probability": 0.6}, T, M)
    prev = run_reference(f"BODY = {target!r}\nREPEATS = {args.repeats}\n" + PREVIOUS, commit=PREVIOUS_COMMIT)["cpu"]
    rows.append((f"the same, main at {PREVIOUS_COMMIT} (same run)", f"{prev:.2f} s", f"{prev / (M * T) * 1e9:.0f} ns"))
    rows.append(("ratio previous / now", f"{prev / t_vec:.1f}x", ""))

    sim, opts = sim_system(req), parse_options(req, BIG)
    k = args.loop_trajectories
    t_loop, _ = timed(lambda: python_loop(sim.A, sim.C, sim.Q, sim.R, 0.6, opts.P0, k, T, 0), 1)
    t_loop_full = t_loop * M / k
    rows.append(
        (f"per-trajectory Python loop, {k} x {T}, measured", f"{t_loop:.2f} s", f"{t_loop / (k * T) * 1e9:.0f} ns")
    )
    rows.append((f"per-trajectory Python loop, {M} x {T}, extrapolated", f"{t_loop_full:.0f} s", ""))
    rows.append(("ratio loop / vectorized (extrapolated)", f"{t_loop_full / t_vec:.0f}x", ""))

    two = request(
        TWO_PACKETS,
        {
            "model": "per_sensor",
            "channels": {
                "s1": {"model": "bernoulli", "arrival_probability": 0.5},
                "s2": {"model": "gilbert_elliott", "failure_rate": 0.2, "recovery_rate": 0.4},
            },
        },
        50,
        M,
    )
    sim2, opts2 = sim_system(two), parse_options(two, BIG)
    masked = RiccatiStep.build(sim2.A, sim2.Q, sim2.C, sim2.R)
    grouped = GroupedRiccatiStep(sim2.A, sim2.Q, sim2.C, sim2.R)
    t_packed, _ = timed(lambda: run_monte_carlo(sim2, opts2), args.repeats)
    t_mask, _ = timed(lambda: run_monte_carlo(sim2, opts2, update=masked), args.repeats)
    t_group, _ = timed(lambda: run_monte_carlo(sim2, opts2, update=grouped), args.repeats)
    for what, t in (
        ("packed kernel, masking (default)", t_packed),
        ("matrix kernel, masking", t_mask),
        ("matrix kernel, grouping by pattern", t_group),
    ):
        rows.append((f"two packets, n = 2, {M} x 50, {what}", f"{t:.2f} s", f"{t / (M * 50) * 1e9:.0f} ns"))

    ex = request(SEED004, {"model": "gilbert_elliott", "failure_rate": 0.3, "recovery_rate": 0.4}, 200, 100)
    t_ex, _ = timed(lambda: expected_covariance(ex, 20), 1)
    rows.append(
        (
            "exact E[P_t], n = 3, Gilbert-Elliott, 2^20 sequences (t <= 20)",
            f"{t_ex:.2f} s",
            f"{t_ex / 2**21 * 1e9:.0f} ns / matrix",
        )
    )

    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(
        f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, NumPy {np.__version__}, "
        f"OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}, load average {load:.1f}"
    )
    print(f"CPU time; best of {args.repeats} for the vectorized runs; the Python loop ran once\n")
    print("| what | time | per trajectory-step |")
    print("|---|---|---|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]} |")
    print(f"\nmean trace(P_200) = {rep.mean_trace[-1]:.1f} (95% band {rep.ci95[0][-1]:.1f} .. {rep.ci95[1][-1]:.1f})")


if __name__ == "__main__":
    main()
