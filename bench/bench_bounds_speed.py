"""``kfio bounds`` end to end: CPU of ``compute_bounds`` against a reference commit, same run.

    python bench/bench_bounds_speed.py [--reference 13e923d] [--sizes 3,10,20] [--examples FILE,...] [--repeat R] [--rounds K]

For each size, one system of ``bench_bounds.random_system`` (seed 0, two outputs, ``Q = I``,
``R = I``, Bernoulli ``0.9``) goes through :func:`kfio.riccati_bounds._compute.compute_bounds` (the work of
``kfio bounds``: interval, covariance bounds with the SDP cross-check, ``P_hat``), timed with
``time.process_time`` here and in a child interpreter on the reference code (:mod:`_reference`).
The JSON of both reports is compared too.  ``--examples`` times request files instead (the
median of ``--repeat`` runs each, after one warm-up run: a small request is milliseconds).
``--rounds K`` runs the two children ``K`` times, alternately, and keeps each side's smallest
time: on a loaded machine the load changes between the two children's runs, and CPU time only
grows with contention (caches and cores shared), so the smallest is the fairest estimate.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

# ``time.process_time`` adds the CPU of every BLAS thread: with two, the same work at n = 20
# measured 2.6-2.9 s against 0.6 s with one. Both children inherit one thread each (unless set).
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _reference import run_reference  # noqa: E402


def request_text(n: int) -> str:
    """The bounds request of size ``n`` (entries rounded to 3 decimals, spectral radius about 1.2)."""
    import numpy as np
    from bench_bounds import random_system

    A, C = random_system(np.random.default_rng(0), n, 2)
    return json.dumps(
        {
            "system": {
                "A": [[repr(float(x)) for x in r] for r in A],
                "C": [[repr(float(x)) for x in r] for r in C],
                "Q": np.eye(n).tolist(),
                "R": np.eye(2).tolist(),
            },
            "channel": {"model": "bernoulli", "arrival_probability": "0.9"},
            "options": {"time_budget_s": 3000},
        }
    )


def measure(sizes: list[int]) -> dict:
    """CPU seconds of ``compute_bounds`` per size, and the JSON text of each report."""
    import time

    from kfio import load_request
    from kfio.riccati_bounds._compute import compute_bounds

    compute_bounds(load_request(request_text(2)))  # imports and CVXPY's first solve
    out = {}
    for n in sizes:
        req = load_request(request_text(n))
        t = time.process_time()
        report = compute_bounds(req)
        out[str(n)] = [time.process_time() - t, json.dumps(report.to_dict(), sort_keys=True, default=str)]
    return out


def measure_files(paths: list[str], repeat: int) -> dict:
    """Median CPU seconds of ``compute_bounds`` over ``repeat`` runs per request file, and its JSON text."""
    import statistics
    import time

    from kfio import load_request
    from kfio.riccati_bounds._compute import compute_bounds

    out = {}
    for path in paths:
        text = Path(path).read_text()
        report = compute_bounds(load_request(text))  # imports, CVXPY's first solve, compiled SDP
        times = []
        for _ in range(repeat):
            req = load_request(text)
            t = time.process_time()
            report = compute_bounds(req)
            times.append(time.process_time() - t)
        out[Path(path).name] = [statistics.median(times), json.dumps(report.to_dict(), sort_keys=True, default=str)]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reference", default="13e923d", help="commit whose code is timed beside this one")
    ap.add_argument("--sizes", default="3,10,20")
    ap.add_argument("--examples", default="", help="comma-separated request files, timed instead of --sizes")
    ap.add_argument("--repeat", type=int, default=20)
    ap.add_argument("--rounds", type=int, default=1, help="alternate the two children this many times")
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",") if s]
    bench = str(Path(__file__).resolve().parent)
    child = f"import json, sys; sys.path.insert(0, {bench!r}); from bench_bounds_speed import measure, measure_files\n"
    if args.examples:
        files = [str(Path(f).resolve()) for f in args.examples.split(",") if f]
        code = child + f"print(json.dumps(measure_files({files}, {args.repeat})))"
    else:
        code = child + f"print(json.dumps(measure({sizes})))"
    olds, nows = [], []
    for _ in range(max(1, args.rounds)):
        olds.append(run_reference(code, args.reference))
        # this checkout in a fresh interpreter too: timed in this process after the child, the same
        # small request measured 1.6x slower than in a fresh process (the ratio would be the harness's)
        done = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
        nows.append(json.loads(done.stdout.strip().splitlines()[-1]))
    old = {k: [min(r[k][0] for r in olds), olds[-1][k][1]] for k in olds[-1]}
    now = {k: [min(r[k][0] for r in nows), nows[-1][k][1]] for k in nows[-1]}
    print(
        f"load average {os.getloadavg()[0]:.1f}; CPU s of compute_bounds (time.process_time), same run,"
        f" smallest of {max(1, args.rounds)} alternating round(s)"
    )
    print(f"| n | now | {args.reference} | ratio | same JSON |")
    print("|---|---|---|---|---|")
    for n in now:
        print(f"| {n} | {now[n][0]:.3g} | {old[n][0]:.3g} | {old[n][0] / now[n][0]:.2f}x | {now[n][1] == old[n][1]} |")


if __name__ == "__main__":
    main()
