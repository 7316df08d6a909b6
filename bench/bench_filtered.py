"""Cost of the filtered covariance P(t|t) inside ``kfio simulate``, now and before, in one run.

    python bench/bench_filtered.py [--trajectories 100000] [--steps 200] [--repeats 3]

The target run of ``bench/bench_simulate.py`` (Sinopoli et al. (2004)'s 3x3 system, Bernoulli
lambda = 0.6, 10^5 trajectories x 200 steps) through
:func:`kfio.simulation._simulate.run_monte_carlo`, CPU seconds (``time.process_time``), best of
``--repeats``, one BLAS thread (``OPENBLAS_NUM_THREADS=1`` unless set):

* now, with the filtered statistics (the default) and without (``filtered=False``);
* main before this kernel (``PREVIOUS_COMMIT``: the packed kernel, which unpacked the batch and called
  ``filtered_covariance`` every step), and main before the filtered covariance was added
  (``BEFORE_FILTERED``), each in a child interpreter on its own library (``bench/_reference.py``).
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
from kfio.simulation._setup import SimulationLimits, parse_options, sim_system  # noqa: E402
from kfio.simulation._simulate import run_monte_carlo  # noqa: E402

#: main before the blocked kernel (filtered P(t|t) by an unpack and ``filtered_covariance`` per step).
PREVIOUS_COMMIT = "7299885"
#: main just before the filtered covariance was merged (predictor only).
BEFORE_FILTERED = "29cf546"

SYSTEM = {
    "A": [[1.25, 1, 0], [0, 0.9, 7], [0, 0, 0.6]],
    "C": [[1, 0, 2]],
    "Q": [[20, 0, 0], [0, 20, 0], [0, 0, 20]],
    "R": [[2.5]],
}

RUN = """
import json, time
from kfio import load_request
from kfio.simulation._setup import SimulationLimits, parse_options, sim_system
from kfio.simulation._simulate import run_monte_carlo
req = load_request(BODY)
limits = SimulationLimits(max_trajectory_steps=10**9, max_batch_floats=10**9)
sim, opts = sim_system(req), parse_options(req, limits)
best = float("inf")
for _ in range(REPEATS):
    t0 = time.process_time()
    run = run_monte_carlo(sim, opts)
    best = min(best, time.process_time() - t0)
print(json.dumps({"cpu": best, "mean_T": float(run.stats.mean[-1])}))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trajectories", type=int, default=100_000)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    body = json.dumps(
        {
            "system": SYSTEM,
            "channel": {"model": "bernoulli", "arrival_probability": 0.6},
            "options": {"simulate": {"steps": args.steps, "trajectories": args.trajectories, "seed": 0}},
        }
    )
    req = load_request(body)
    limits = SimulationLimits(max_trajectory_steps=10**9, max_batch_floats=10**9)
    sim, opts = sim_system(req), parse_options(req, limits)
    now = {}
    for filtered in (True, False):
        t = float("inf")
        for _ in range(args.repeats):
            t0 = time.process_time()
            run = run_monte_carlo(sim, opts, filtered=filtered)
            t = min(t, time.process_time() - t0)
        now[filtered] = (t, float(run.stats.mean[-1]))
    snippet = f"BODY = {body!r}\nREPEATS = {args.repeats}\n" + RUN
    previous = run_reference(snippet, commit=PREVIOUS_COMMIT)
    before = run_reference(snippet, commit=BEFORE_FILTERED)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    M, T = args.trajectories, args.steps
    print(
        f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
        f"NumPy {np.__version__}, OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}, load average {load:.1f}"
    )
    print(f"run_monte_carlo, n = 3, {M} x {T}, CPU s, best of {args.repeats}, same run\n")
    print("| code | filtered P(t\\|t) | CPU s | per trajectory-step | vs now (with filtered) |")
    print("|---|---|---|---|---|")
    base = now[True][0]
    table = [
        ("now", "yes", now[True][0]),
        ("now", "no (`filtered=False`)", now[False][0]),
        (f"main at {PREVIOUS_COMMIT} (unpack + `filtered_covariance` per step)", "yes", previous["cpu"]),
        (f"main at {BEFORE_FILTERED} (before P(t\\|t))", "no", before["cpu"]),
    ]
    for code, filt, t in table:
        print(f"| {code} | {filt} | {t:.2f} | {t / (M * T) * 1e9:.0f} ns | {t / base:.2f}x |")
    print(f"\nshare of the filtered statistics now: {100 * (now[True][0] - now[False][0]) / now[True][0]:.0f}%")
    means = [now[True][1], now[False][1], previous["mean_T"], before["mean_T"]]
    print(f"mean trace(P_T) in the four runs: {', '.join(f'{m:.12g}' for m in means)}")


if __name__ == "__main__":
    main()
