"""Sweep benchmark: a 1000-point channel sweep of a seed system, against 1000 independent analyses.

Routes, in one run:

* ``independent``: 1000 x (``load_request`` + ``analyze``), the naive baseline;
* ``serial, reuse``: :func:`kfio.sweep.run_sweep` in this process (FMO blocks once, verdicts cached);
* ``local cluster``: the same on an embedded Dask LocalCluster (2 worker processes), with and
  without reuse (cluster start-up included: that is what ``kfio sweep`` pays).

Prints wall seconds, points per second and the ratio to the baseline.

``--cli 10000,100000`` times ``kfio sweep FILE --out table.csv --quiet`` end to end (embedded
LocalCluster of 2 workers) on a grid of ``A[0][0]`` (10 values per 10^4 points) x the arrival
probability, for this code and, in the same run, for the code of ``--against`` (a commit, run
from ``git archive`` by ``bench/_reference.py``): wall seconds, points/s, CPU seconds of the
client and of its workers, and the peak RSS of the client and of the largest worker.  The two
tables must be equal byte for byte.  ``--scheduler tcp://HOST:PORT`` adds a run of this code on
a cluster started by hand (``dask scheduler``, ``dask worker``); ``--serial`` adds a run of this code in one
process (``kfio sweep --serial``), and of the ``--against`` code too when both are given.
Usage: ``python bench/bench_sweep.py [--points 1000] [--cli 10000,100000 [--against 4d603a0]]``
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from kfio import analyze, load_request
from kfio.sweep import clear_caches, load_sweep, point_at, run_sweep
from kfio.sweep._spec import request_text

SEED = {
    "system": {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]], "Q": [[20, 0], [0, 20]], "R": [[2.5]]},
    "channel": {"model": "bernoulli", "arrival_probability": 0.5},
}


#: The commit this round of sweep work started from.
START_COMMIT = "4d603a0"

#: Runs ``kfio sweep`` in this interpreter and prints its resource use as the last JSON line.
_CLI = """
import json, resource, sys, time
from kfio.service.cli import main
t0 = time.perf_counter()
code = main(sys.argv[1:])
wall = time.perf_counter() - t0
me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
print(json.dumps({"code": code, "wall": wall, "cpu_client": me.ru_utime + me.ru_stime,
                  "cpu_workers": kids.ru_utime + kids.ru_stime, "rss_client_mb": me.ru_maxrss / 1024,
                  "rss_worker_mb": kids.ru_maxrss / 1024}))
"""


def grid(points: int) -> dict:
    """``A[0][0]`` from 1.05 to 1.5 (one value per 1000 points) x the arrival probability from 1/100 to 99/100."""
    n_a = max(1, points // 1000)
    return {
        "command": "analyze",
        "base": SEED,
        "axes": [
            {"pointer": "/system/A/0/0", "name": "a11", "from": "1.05", "to": "1.5", "num": n_a},
            {
                "pointer": "/channel/arrival_probability",
                "name": "p",
                "from": "1/100",
                "to": "99/100",
                "num": points // n_a,
            },
        ],
    }


def run_cli(args: list[str], pythonpath: str | None = None, timeout: float = 3600) -> dict:
    """``kfio sweep ARGS`` in a child interpreter (the library of ``pythonpath`` first if given)."""
    env = dict(os.environ)
    if pythonpath is not None:
        env["PYTHONPATH"] = pythonpath
    out = subprocess.run(
        [sys.executable, "-c", _CLI, "sweep", *args], env=env, capture_output=True, text=True, timeout=timeout
    )
    if out.returncode != 0:
        raise SystemExit(out.stderr[-2000:])
    return json.loads(out.stdout.strip().splitlines()[-1])


def cli_section(sizes: list[int], against: str | None, scheduler: str | None, serial: bool = False) -> None:
    from _reference import reference_tree

    ref = str(reference_tree(against)) if against else None
    print(f"kfio sweep FILE --out table.csv --quiet --workers 2, {os.cpu_count()} cores")
    head = f"{'points':>7s} {'code':10s} {'wall s':>7s} {'points/s':>9s} {'CPU client':>10s} {'CPU workers':>11s}"
    print(head + f" {'RSS client MB':>13s} {'RSS worker MB':>13s}")
    with tempfile.TemporaryDirectory() as tmp:
        for n in sizes:
            path = Path(tmp) / f"grid{n}.json"
            path.write_text(json.dumps(grid(n)))
            runs = [("this", ["--workers", "2"], None)]
            if ref is not None:
                runs.append((against, ["--workers", "2"], ref))
            if scheduler:
                runs.append(("this, ext", ["--scheduler", scheduler], None))
            if serial:
                runs.append(("this, ser", ["--serial"], None))
                if ref is not None:
                    runs.append((f"{against}, ser", ["--serial"], ref))
            tables, walls = {}, {}
            load = os.getloadavg()[0]
            for label, extra, pypath in runs:
                out = Path(tmp) / f"{label}-{n}.csv".replace(" ", "").replace(",", "")
                r = run_cli([str(path), "--quiet", "--no-progress", "--out", str(out), *extra], pypath)
                tables[label], walls[label] = out.read_bytes(), r["wall"]
                out.unlink()
                print(
                    f"{n:7d} {label:10s} {r['wall']:7.1f} {n / r['wall']:9.0f} {r['cpu_client']:10.1f} "
                    f"{r['cpu_workers']:11.1f} {r['rss_client_mb']:13.0f} {r['rss_worker_mb']:13.0f}"
                )
            if ref is not None:
                print(
                    f"{'':7s} speed-up of this over {against}: {walls[against] / walls['this']:.2f}x (load {load:.1f})"
                )
            first = tables["this"]
            assert all(t == first for t in tables.values()), "the tables differ between runs"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--points", type=int, default=1000)
    ap.add_argument("--cli", help="comma-separated sweep sizes for the end-to-end kfio sweep section")
    ap.add_argument("--against", default=START_COMMIT, help="commit to compare the CLI section with ('' for none)")
    ap.add_argument("--scheduler", help="also run the CLI section on this Dask scheduler")
    ap.add_argument(
        "--serial", action="store_true", help="also run the CLI section in one process (kfio sweep --serial)"
    )
    args = ap.parse_args()
    if args.cli:
        cli_section([int(x) for x in args.cli.split(",")], args.against or None, args.scheduler, args.serial)
        return
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
