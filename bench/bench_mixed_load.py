"""Small analyze latency beside four budget-length loop requests, without and with the cheap lane (loopback only).

With the default 2 workers and four 8-second loop requests
in flight, a 1x1 analyze waited 7.7 s (p50).  This starts ``kfio serve`` of
this checkout twice, with the default worker count (``--workers``, 2), the
cache off and a fresh job database:

* ``no lane``: ``KFIO_LANE_WORKERS=0`` (every request shares the regular
  workers, none reserved);
* ``lane``: the default, one reserved worker for cheap requests
  (:mod:`kfio.service.lanes`).

In each, ``--heavy`` clients (4) post a loop of ``n = 4`` states over
Gilbert-Elliott links with ``options.time_budget_s = 8`` over and over (its
exact critical values take about that long: each holds a worker for 5 to 8 s), and ``--small`` clients (8)
post 1x1 analyze requests (a new arrival probability each time, so never
cached) one after another for ``--duration`` seconds (60), after the heavy
ones have filled the workers.  It prints, per scenario, the small requests'
count, status codes and p50/p90/p99 latency, the heavy requests' status
codes, and the ratio no lane / lane of each percentile.

Usage::

    python bench/bench_mixed_load.py
    python bench/bench_mixed_load.py --duration 30 --small 32

Every request has a timeout; the figures are wall-clock seconds on this machine.
"""

from __future__ import annotations

import argparse
import json
import sys
import threading
import time
from collections import Counter
from pathlib import Path
from typing import Any

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from support.live_server import JSON_HEADERS, LiveServer  # noqa: E402

HEAVY_BUDGET_S = 8


def heavy_loop(k: int, n: int = 4) -> bytes:
    """A loop of ``n`` states over Gilbert-Elliott links, about as long as its 8 s budget.

    Its exact critical values take 5 to 11 s in a warm worker on this project's
    machines (the report gives what the budget allowed).  ``k`` changes the
    failure rate in its fifth decimal, so no two requests share a computation.
    """
    eye = [[1 if i == j else 0 for j in range(n)] for i in range(n)]
    A = [["11/10" if i == j else ("1/10" if j == i + 1 else 0) for j in range(n)] for i in range(n)]
    gain = [["3/5" if i == j else 0 for j in range(n)] for i in range(n)]
    link = {"model": "gilbert_elliott", "failure_rate": f"0.1{k % 10000:04d}", "recovery_rate": 0.8}
    body = {
        "system": {"A": A, "B": eye, "C": eye, "Q": eye, "R": eye},
        "channel": link,
        "actuator_channel": link,
        "controller": {"gains": {"estimator": gain, "feedback": gain}, "form": "predictor"},
        "cost": {"W": eye, "U": eye},
        "options": {"loop": {"protocol": "tcp", "on_loss": "zero"}, "time_budget_s": HEAVY_BUDGET_S},
    }
    return json.dumps(body).encode()


def small_analyze(k: int) -> bytes:
    """A 1x1 analyze whose arrival probability ``k / 10^6`` (plus 1/2) makes it new each time."""
    p = f"0.{500000 + k % 499999:06d}"
    return json.dumps(
        {"system": {"A": [[2]], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": p}}
    ).encode()


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def scenario(lane: bool, args: argparse.Namespace) -> dict[str, Any]:
    env = {"KFIO_LANE_WORKERS": "1" if lane else "0", "KFIO_CACHE_ENTRIES": "0", "KFIO_MAX_QUEUE": "256"}
    heavy_codes: Counter[str] = Counter()
    small_codes: Counter[str] = Counter()
    latencies: list[float] = []
    lock = threading.Lock()
    with LiveServer(env=env, workers=args.workers) as server:
        stop = threading.Event()
        counter = iter(range(10**9))

        def heavy() -> None:
            with httpx.Client(timeout=60) as client:
                while not stop.is_set():
                    with lock:
                        k = next(counter)
                    try:
                        code = str(
                            client.post(
                                f"{server.url}/v1/loop", content=heavy_loop(k), headers=JSON_HEADERS
                            ).status_code
                        )
                    except httpx.HTTPError as exc:
                        code = type(exc).__name__
                    with lock:
                        heavy_codes[code] += 1

        def small(end: float) -> None:
            with httpx.Client(timeout=60) as client:
                while time.monotonic() < end:
                    with lock:
                        k = next(counter)
                    t0 = time.perf_counter()
                    try:
                        code = str(
                            client.post(
                                f"{server.url}/v1/analyze", content=small_analyze(k), headers=JSON_HEADERS
                            ).status_code
                        )
                    except httpx.HTTPError as exc:
                        code = type(exc).__name__
                    with lock:
                        latencies.append(time.perf_counter() - t0)
                        small_codes[code] += 1

        heavies = [threading.Thread(target=heavy, daemon=True) for _ in range(args.heavy)]
        for t in heavies:
            t.start()
        deadline = time.monotonic() + 60
        while httpx.get(f"{server.url}/readyz").json()["pool"]["busy"] < args.workers:
            if time.monotonic() > deadline:
                raise RuntimeError("the heavy requests never filled the workers")
            time.sleep(0.05)
        end = time.monotonic() + args.duration
        smalls = [threading.Thread(target=small, args=(end,), daemon=True) for _ in range(args.small)]
        for t in smalls:
            t.start()
        for t in smalls:
            t.join(args.duration + 120)
        stop.set()
        for t in heavies:
            t.join(HEAVY_BUDGET_S + 60)
        stats = httpx.get(f"{server.url}/readyz").json()["pool"]
    return {
        "name": "lane" if lane else "no lane",
        "count": len(latencies),
        "codes": dict(small_codes),
        "heavy": dict(heavy_codes),
        "p50": percentile(latencies, 0.50),
        "p90": percentile(latencies, 0.90),
        "p99": percentile(latencies, 0.99),
        "moved": stats.get("moved"),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=60.0, help="seconds of small requests per scenario")
    parser.add_argument("--heavy", type=int, default=4, help="clients posting budget-length loops")
    parser.add_argument("--small", type=int, default=8, help="clients posting 1x1 analyze requests")
    parser.add_argument("--workers", type=int, default=2, help="regular workers (the default on 2 cores)")
    args = parser.parse_args()
    rows = [scenario(False, args), scenario(True, args)]
    print(
        f"{args.workers} workers, {args.heavy} heavy loop clients ({HEAVY_BUDGET_S} s budget), {args.small} small clients, {args.duration:g} s"
    )
    print("| scenario | small requests | status codes | p50 s | p90 s | p99 s | heavy status codes | moved |")
    print("|---|---:|---|---:|---:|---:|---|---:|")
    for r in rows:
        print(
            f"| {r['name']} | {r['count']} | {r['codes']} | {r['p50']:.3f} | {r['p90']:.3f} | {r['p99']:.3f} | {r['heavy']} | {r['moved']} |"
        )
    before, after = rows
    ratios = ", ".join(f"{q} {before[q] / after[q]:.1f}x" for q in ("p50", "p90", "p99"))
    print(f"no lane / lane: {ratios}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
