"""Sweep benchmark: a 1000-point channel sweep of a seed system, against 1000 independent analyses.

Routes, in one run:

* ``independent``: 1000 x (``load_request`` + ``analyze``), the naive baseline;
* ``serial, reuse``: :func:`kfio.sweep.run_sweep` in this process (FMO blocks once, verdicts cached);
* ``local cluster``: the same on an embedded Dask LocalCluster (2 worker processes), with and
  without reuse (cluster start-up included: that is what ``kfio sweep`` pays).

Prints wall seconds, points per second and the ratio to the baseline.
Usage: ``python bench/bench_sweep.py [--points 1000]``
"""

from __future__ import annotations

import argparse
import json
import os
import time

from kfio import analyze, load_request
from kfio.sweep import clear_caches, load_sweep, point_at, run_sweep
from kfio.sweep._spec import request_text

SEED = {
    "system": {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]], "Q": [[20, 0], [0, 20]], "R": [[2.5]]},
    "channel": {"model": "bernoulli", "arrival_probability": 0.5},
}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--points", type=int, default=1000)
    args = ap.parse_args()
    spec = load_sweep(
        json.dumps(
            {
                "command": "analyze",
                "base": SEED,
                "axes": [
                    {"pointer": "/channel/arrival_probability", "from": "1/10", "to": "99/100", "num": args.points}
                ],
            }
        )
    )
    texts = [request_text(point_at(spec, i).request) for i in range(spec.size)]
    analyze(load_request(texts[0]))  # warm imports
    t0 = time.perf_counter()
    base_rows = [analyze(load_request(t)).verdict for t in texts]
    t_base = time.perf_counter() - t0
    results = [("independent (load_request + analyze)", t_base, base_rows)]
    for label, kw in [
        ("serial sweep, reuse", {"engine": "serial"}),
        ("serial sweep, no reuse", {"engine": "serial", "reuse": False}),
        ("local cluster (2 workers), reuse", {"workers": 2}),
        ("local cluster (2 workers), no reuse", {"workers": 2, "reuse": False}),
    ]:
        clear_caches()
        t0 = time.perf_counter()
        res = run_sweep(spec, **kw)
        results.append((label, time.perf_counter() - t0, [r.fields["verdict"] for r in res.rows]))
    print(
        f"{spec.size}-point channel sweep of the 2x2 seed system (Sinopoli et al. 2004), {os.cpu_count()} cores, "
        f"load average {os.getloadavg()[0]:.1f}"
    )
    print(f"{'route':40s} {'wall s':>8s} {'points/s':>9s} {'speed-up':>9s}")
    for label, t, rows in results:
        assert rows == base_rows, f"{label}: rows differ from the independent analyses"
        print(f"{label:40s} {t:8.2f} {spec.size / t:9.1f} {t_base / t:8.1f}x")


if __name__ == "__main__":
    main()
