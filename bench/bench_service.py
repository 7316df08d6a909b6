"""Load benchmark of the HTTP service over loopback (a benchmark, not a test).

Starts ``kfio serve`` on a free port of 127.0.0.1 (or uses ``--url``), then
runs each scenario for ``--duration`` seconds with ``--clients`` concurrent
clients, each sending one request at a time:

=================  ============================================================
scenario           what every request is
=================  ============================================================
analyze-cached     one of the seed systems (docs/theory.md), answered from
                   the cache after its first time
analyze-uncached   a seed system with an arrival probability never sent before
bounds-uncached    the same, for ``POST /v1/bounds``
simulate-uncached  a seed system, 200 steps x 2000 trajectories, a new seed each
fast-under-slow    ``--slow`` clients keep the pool busy with slow requests
                   (the largest exact Q allowed: 40x40 of 190-digit fractions,
                   cut off at a 5 s budget); one client sends uncached seed
                   analyses, whose latency is what is reported
=================  ============================================================

Usage::

    python bench/bench_service.py                       # all scenarios, 30 s each
    python bench/bench_service.py --duration 10 --scenarios analyze-cached

Prints a Markdown table: requests per second, p50/p99 latency, and the
status codes seen.  The server (with its workers) and this load generator run
on disjoint CPUs (``--server-cpus``, ``--client-cpus``; by default the last CPU
for the client and the others for the server, so with 2 cores: workers on
CPU 0, clients on CPU 1), set with ``os.sched_setaffinity`` before the server
starts (its processes inherit it), so that the figures are the server's.
"""

from __future__ import annotations

import argparse
import asyncio
import copy
import itertools
import json
import os
import platform
import sys
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from kfio.service.api.schemas import REQUEST_EXAMPLES  # noqa: E402

from support.live_server import SLOW_PATH, LiveServer, slow_request  # noqa: E402

#: One-packet seed systems (per-sensor systems are left out: simulate/bounds treat them alike).
SEEDS = [REQUEST_EXAMPLES[k]["value"] for k in ("seed004-scalar", "seed004-3x3", "seed002-2x2")]
_unique = itertools.count(1)


def analyze_body(i: int, unique: bool) -> bytes:
    body = copy.deepcopy(SEEDS[i % len(SEEDS)])
    if unique:  # a probability never sent before: a cache miss
        body["channel"]["arrival_probability"] = f"{600000 + next(_unique)}/1000000"
    return json.dumps(body).encode()


def simulate_body(i: int) -> bytes:
    body = copy.deepcopy(SEEDS[i % len(SEEDS)])
    body["channel"]["arrival_probability"] = 0.7
    body["options"] = {"simulate": {"steps": 200, "trajectories": 2000, "seed": next(_unique)}}
    return json.dumps(body).encode()


@dataclass
class Result:
    scenario: str
    latencies: list[float] = field(default_factory=list)
    statuses: Counter[int] = field(default_factory=Counter)
    elapsed: float = 0.0

    def row(self) -> str:
        lat = sorted(self.latencies)

        def pct(q: float) -> str:
            return f"{1000 * lat[min(len(lat) - 1, int(q * len(lat)))]:.1f}" if lat else "-"

        rps = len(lat) / self.elapsed if self.elapsed else 0.0
        codes = ", ".join(f"{k}: {v}" for k, v in sorted(self.statuses.items()))
        return f"| {self.scenario} | {len(lat)} | {rps:.1f} | {pct(0.50)} | {pct(0.99)} | {codes} |"


async def closed_loop(
    client: httpx.AsyncClient,
    path: str,
    make_body: Callable[[int], bytes],
    clients: int,
    duration: float,
    result: Result,
) -> None:
    """``clients`` loops, each sending its next request when the previous one is answered."""
    stop = time.monotonic() + duration

    async def one(worker: int) -> None:
        for i in itertools.count(worker * 100_000):
            if time.monotonic() >= stop:
                return
            body = make_body(i)
            t0 = time.perf_counter()
            r = await client.post(path, content=body, headers={"content-type": "application/json"})
            result.latencies.append(time.perf_counter() - t0)
            result.statuses[r.status_code] += 1

    t0 = time.monotonic()
    await asyncio.gather(*(one(w) for w in range(clients)))
    result.elapsed = time.monotonic() - t0


async def fast_under_slow(client: httpx.AsyncClient, slow_clients: int, duration: float) -> tuple[Result, Result]:
    result = Result("fast-under-slow")
    slow_result = Result("(slow requests)")
    # every slow request distinct: identical ones would share one computation
    slow = asyncio.create_task(
        closed_loop(
            client,
            SLOW_PATH,
            lambda i: slow_request(time_budget_s=5, seed=next(_unique)),
            slow_clients,
            duration,
            slow_result,
        )
    )
    await asyncio.sleep(0.5)  # let the slow ones occupy the pool first
    await closed_loop(client, "/v1/analyze", lambda i: analyze_body(i, unique=True), 1, duration - 0.5, result)
    await slow
    return result, slow_result


async def run(url: str, scenarios: list[str], clients: int, duration: float, slow_clients: int) -> list[Result]:
    limits = httpx.Limits(max_connections=clients + slow_clients + 2)
    async with httpx.AsyncClient(base_url=url, timeout=120, limits=limits) as client:
        results = []
        for name in scenarios:
            if name == "fast-under-slow":
                results.extend(await fast_under_slow(client, slow_clients, duration))
                continue
            path, make = {
                "analyze-cached": ("/v1/analyze", lambda i: analyze_body(i, unique=False)),
                "analyze-uncached": ("/v1/analyze", lambda i: analyze_body(i, unique=True)),
                "bounds-uncached": ("/v1/bounds", lambda i: analyze_body(i, unique=True)),
                "simulate-uncached": ("/v1/simulate", simulate_body),
            }[name]
            result = Result(name)
            await closed_loop(client, path, make, clients, duration, result)
            results.append(result)
        return results


def _cpu_split(server: str | None, client: str | None) -> tuple[set[int], set[int]]:
    """Disjoint CPU sets for the server and the load generator (with one CPU, both share it)."""
    cpus = sorted(os.sched_getaffinity(0))

    def parse(text: str) -> set[int]:
        return {int(x) for x in text.split(",") if x}

    c = parse(client) if client else {cpus[-1]}
    s = parse(server) if server else (set(cpus) - c or set(cpus))
    return s, c


def main(argv: list[str] | None = None) -> int:
    all_scenarios = ["analyze-cached", "analyze-uncached", "bounds-uncached", "simulate-uncached", "fast-under-slow"]
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--url", help="benchmark a running server instead of starting one")
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1, help="--workers of the started server")
    p.add_argument("--clients", type=int, default=16)
    p.add_argument("--slow", type=int, default=4, help="clients sending slow requests in fast-under-slow")
    p.add_argument("--duration", type=float, default=30.0, help="seconds per scenario")
    p.add_argument("--scenarios", nargs="+", default=all_scenarios, choices=all_scenarios)
    p.add_argument(
        "--server-cpus",
        default=None,
        help="CPUs for the started server and its workers, e.g. 0 (default: all but the last when there are 2+)",
    )
    p.add_argument("--client-cpus", default=None, help="CPUs for this load generator, e.g. 1 (default: the last)")
    args = p.parse_args(argv)
    server_cpus, client_cpus = _cpu_split(args.server_cpus, args.client_cpus)

    def go(url: str) -> list[Result]:
        return asyncio.run(run(url, args.scenarios, args.clients, args.duration, args.slow))

    if args.url:
        os.sched_setaffinity(0, client_cpus)
        results = go(args.url)
        workers = "?"
    else:
        # The server, its forkserver and every worker inherit the affinity of the process that starts them:
        # pin ourselves to the server's CPUs, start it, then move the load generator to its own CPUs.
        os.sched_setaffinity(0, server_cpus)
        with LiveServer(workers=args.workers) as server:
            os.sched_setaffinity(0, client_cpus)
            results = go(server.url)
        workers = str(args.workers)
    print(
        f"kfio service on 127.0.0.1, {workers} workers, {os.cpu_count()} cores, Python {platform.python_version()}; "
        f"{args.clients} clients x {args.duration:g} s per scenario ({args.slow} slow clients in fast-under-slow); "
        f"server pinned to CPUs {sorted(server_cpus)}, load generator to CPUs {sorted(client_cpus)} "
        f"(os.sched_setaffinity; load average at the end {os.getloadavg()[0]:.1f})\n"
    )
    print("| scenario | requests | req/s | p50 ms | p99 ms | status codes |")
    print("|---|---:|---:|---:|---:|---|")
    for r in results:
        print(r.row())
    return 0


if __name__ == "__main__":
    sys.exit(main())
