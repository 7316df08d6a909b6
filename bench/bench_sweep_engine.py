"""Where a sweep is cheapest: in this process, on the embedded Dask cluster, or as ``engine="auto"`` picks.

    python bench/bench_sweep_engine.py [--points 13,52,208] [--workers 2] [--sim-points 4,16,64]

Each row runs one sweep end to end, in a fresh child interpreter (as ``kfio sweep`` would: the
imports and, for the cluster, its start-up are paid every time), three ways in the same run:

* ``serial``: every point in the child (``engine="serial"``), the baseline;
* ``dask``: an embedded LocalCluster of ``--workers`` processes (``engine="dask"``);
* ``auto``: the default, which times the first points and keeps the sweep in process while the
  estimated work left is under ``AUTO_SERIAL_WORK_S`` (printed with its reason).

Two families of points: the arrival probability of the 2x2 seed plant (``analyze``, about a
millisecond a point) and the same axis under ``simulate`` (tens of milliseconds a point). Wall
seconds are printed with each engine's ratio to ``serial`` and the cluster's overhead (its wall
time less the serial run's divided among its ``W`` workers: start-up, the workers' imports,
shut-down); the last lines give the cluster's bare start-up and the work at which the cluster
starts to pay off, ``overhead x W / (W - 1)``, to compare with ``AUTO_SERIAL_WORK_S``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

BASE = {
    "system": {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]], "Q": [[1, 0], [0, 1]], "R": [[1]]},
    "channel": {"model": "bernoulli", "arrival_probability": 0.5},
}

#: Runs one sweep in a fresh interpreter and prints wall seconds, the engine and its reason.
_CHILD = """
import json, sys, time
t0 = time.perf_counter()
from kfio.sweep import load_sweep, run_sweep
spec = load_sweep(sys.argv[1])
kw = json.loads(sys.argv[2])
res = run_sweep(spec, **kw)
wall = time.perf_counter() - t0
errors = sum(1 for r in res.rows if r.fields.get("error"))
print(json.dumps({"wall": wall, "engine": res.engine, "errors": errors, "rows": len(res.rows)}))
"""

_STARTUP = """
import json, logging, time
from distributed import Client, LocalCluster
t0 = time.perf_counter()
cluster = LocalCluster(n_workers=%d, threads_per_worker=1, processes=True, dashboard_address=None,
                       silence_logs=logging.ERROR)
client = Client(cluster)
client.submit(sum, [1, 2]).result()
t1 = time.perf_counter()
client.close(); cluster.close()
print(json.dumps({"startup": t1 - t0}))
"""


def sweep(command: str, points: int) -> dict:
    base = json.loads(json.dumps(BASE))
    if command == "simulate":
        base["options"] = {"simulate": {"steps": 60, "trajectories": 3000, "seed": 1}}
    axis = {"pointer": "/channel/arrival_probability", "name": "p", "from": "3/10", "to": "9/10", "num": points}
    return {"command": command, "base": base, "axes": [axis], "combine": "grid"}


def run_child(spec: dict, kw: dict) -> dict:
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, json.dumps(spec), json.dumps(kw)],
        capture_output=True,
        text=True,
        check=True,
        timeout=600,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", default="13,52,208", help="analyze sweep sizes")
    ap.add_argument("--sim-points", default="4,16,64", help="simulate sweep sizes")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    from kfio.sweep._engine import AUTO_SERIAL_WORK_S

    print(
        f"| command | points | serial s | dask ({args.workers} workers) s | auto s | auto chose | dask/serial "
        "| auto/best | cluster overhead s |"
    )
    print("|---|---:|---:|---:|---:|---|---:|---:|---:|")
    overheads = []
    cases = [("analyze", int(n)) for n in args.points.split(",")]
    cases += [("simulate", int(n)) for n in args.sim_points.split(",")]
    for command, n in cases:
        spec = sweep(command, n)
        serial = run_child(spec, {"engine": "serial"})
        dask = run_child(spec, {"engine": "dask", "workers": args.workers})
        auto = run_child(spec, {})
        best = min(serial["wall"], dask["wall"])
        # what the cluster costs beyond dividing the serial run's work among its workers
        overhead = dask["wall"] - serial["wall"] / args.workers
        overheads.append(overhead)
        print(
            f"| {command} | {n} | {serial['wall']:.2f} | {dask['wall']:.2f} | {auto['wall']:.2f} | {auto['engine']} "
            f"| {dask['wall'] / serial['wall']:.2f}x | {auto['wall'] / best:.2f}x | {overhead:.2f} |",
            flush=True,
        )
    startup = [
        json.loads(
            subprocess.run(
                [sys.executable, "-c", _STARTUP % args.workers], capture_output=True, text=True, check=True
            ).stdout.strip()
        )["startup"]
        for _ in range(3)
    ]
    s = sorted(startup)[1]
    w = args.workers
    print(
        f"\nembedded cluster start-up ({w} workers, median of 3): {s:.2f} s (runs: {', '.join(f'{x:.2f}' for x in startup)})"
    )
    print(f"work at which the cluster pays off, start-up x W / (W - 1): {s * w / max(1, w - 1):.2f} s")
    print(f"AUTO_SERIAL_WORK_S in kfio.sweep._engine: {AUTO_SERIAL_WORK_S:g} s")


if __name__ == "__main__":
    main()
