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

Prints a Markdown table: requests per second, p50/p99 latency, the
server's CPU per request (its main process, and its worker processes: read
from ``/proc`` for the started server), and the status codes seen.

With ``--reference COMMIT`` the same scenarios then run, pinned the same way, against the
server of an earlier commit of this repository (``git archive``, on ``PYTHONPATH`` of a child
interpreter, as :mod:`_reference` does), and a last table gives the ratios of the same run.
Default: ``73d6773``, the code the speed issue measured (18-22 uncached requests per second
then); ``--reference none`` skips it.

The load generator is a small HTTP/1.1 keep-alive client on asyncio streams,
one connection per client, bodies built before they are timed: it costs
about 0.3 ms of CPU per request.  An ``httpx.AsyncClient`` cost 4-7 ms per
request here and was the bottleneck of the cached scenario (a single core
could not send more than about 170 requests per second).  The server (with its workers) and this load generator run
on disjoint CPUs (``--server-cpus``, ``--client-cpus``; by default the last CPU
for the client and the others for the server, so with 2 cores: workers on
CPU 0, clients on CPU 1), set with ``os.sched_setaffinity`` before the server
starts (its processes inherit it), so that the figures are the server's.
"""

from __future__ import annotations

import argparse
import asyncio
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

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _reference import ROOT, reference_tree, unpack  # noqa: E402

from kfio.service.api.schemas import REQUEST_EXAMPLES  # noqa: E402

from support.live_server import SLOW_PATH, LiveServer, slow_request  # noqa: E402

#: The reference: the service before its worker and cache speed work.
SERVICE_REFERENCE = "73d6773"

#: One-packet seed systems (per-sensor systems are left out: simulate/bounds treat them alike).
SEEDS = [REQUEST_EXAMPLES[k]["value"] for k in ("seed004-scalar", "seed004-3x3", "seed002-2x2")]
_unique = itertools.count(1)


#: The seed bodies with a placeholder for the arrival probability, serialised once.
_TEMPLATES = [
    json.dumps({**b, "channel": {**b["channel"], "arrival_probability": "@P@"}}).encode().split(b'"@P@"') for b in SEEDS
]
_CACHED = [json.dumps(b).encode() for b in SEEDS]


def analyze_body(i: int, unique: bool) -> bytes:
    if not unique:
        return _CACHED[i % len(SEEDS)]
    head, tail = _TEMPLATES[i % len(SEEDS)]  # a probability never sent before: a cache miss
    return head + b'"%d/1000000"' % (600000 + next(_unique)) + tail


def simulate_body(i: int) -> bytes:
    body = json.loads(json.dumps(SEEDS[i % len(SEEDS)]))
    body["channel"]["arrival_probability"] = 0.7
    body["options"] = {"simulate": {"steps": 200, "trajectories": 2000, "seed": next(_unique)}}
    return json.dumps(body).encode()


TABLE_HEAD = (
    "| scenario | requests | req/s | p50 ms | p99 ms | server CPU ms/request (main + workers) | status codes |\n"
    "|---|---:|---:|---:|---:|---:|---|"
)


@dataclass
class Result:
    scenario: str
    latencies: list[float] = field(default_factory=list)
    statuses: Counter[int] = field(default_factory=Counter)
    elapsed: float = 0.0
    server_pid: int | None = None
    #: CPU seconds of the server's main process and of its workers during the scenario
    server_cpu: tuple[float, float] | None = None

    def row(self) -> str:
        lat = sorted(self.latencies)

        def pct(q: float) -> str:
            return f"{1000 * lat[min(len(lat) - 1, int(q * len(lat)))]:.1f}" if lat else "-"

        rps = len(lat) / self.elapsed if self.elapsed else 0.0
        codes = ", ".join(f"{k}: {v}" for k, v in sorted(self.statuses.items()))
        cpu = "-"
        if self.server_cpu is not None and lat:
            main, workers = (1000 * t / len(lat) for t in self.server_cpu)
            # a worker killed at its deadline takes its CPU time with it: only the main process is known
            cpu = f"{main:.2f} + {workers:.2f}" if workers >= 0 else f"{main:.2f} + (workers replaced)"
        return f"| {self.scenario} | {len(lat)} | {rps:.1f} | {pct(0.50)} | {pct(0.99)} | {cpu} | {codes} |"


class Connection:
    """One keep-alive HTTP/1.1 connection: ``post`` sends a body and reads the whole answer."""

    def __init__(self, host: str, port: int) -> None:
        self.host, self.port = host, port
        self.reader: asyncio.StreamReader | None = None
        self.writer: asyncio.StreamWriter | None = None

    async def post(self, path: str, body: bytes) -> int:
        if self.writer is None:
            self.reader, self.writer = await asyncio.open_connection(self.host, self.port)
        assert self.reader is not None
        head = (
            f"POST {path} HTTP/1.1\r\nHost: {self.host}\r\nContent-Type: application/json\r\n"
            f"Content-Length: {len(body)}\r\n\r\n"
        ).encode()
        self.writer.write(head + body)
        await self.writer.drain()
        status_line, _, headers = (await self.reader.readuntil(b"\r\n\r\n")).partition(b"\r\n")
        status = int(status_line.split()[1])
        length, close = 0, False
        for line in headers.split(b"\r\n"):
            name, _, value = line.partition(b":")
            if name.strip().lower() == b"content-length":
                length = int(value)
            elif name.strip().lower() == b"connection" and value.strip().lower() == b"close":
                close = True
        await self.reader.readexactly(length)
        if close:
            self.close()
        return status

    def close(self) -> None:
        if self.writer is not None:
            self.writer.close()
        self.reader = self.writer = None


async def closed_loop(
    url: str,
    path: str,
    make_body: Callable[[int], bytes],
    clients: int,
    duration: float,
    result: Result,
) -> None:
    """``clients`` loops, each sending its next request when the previous one is answered."""
    host, _, port = url.removeprefix("http://").partition(":")
    stop = time.monotonic() + duration

    async def one(worker: int) -> None:
        conn = Connection(host, int(port))
        try:
            for i in itertools.count(worker * 100_000):
                if time.monotonic() >= stop:
                    return
                body = make_body(i)
                t0 = time.perf_counter()
                status = await conn.post(path, body)
                result.latencies.append(time.perf_counter() - t0)
                result.statuses[status] += 1
        finally:
            conn.close()

    cpu0 = server_cpu(result.server_pid)
    t0 = time.monotonic()
    await asyncio.gather(*(one(w) for w in range(clients)))
    result.elapsed = time.monotonic() - t0
    cpu1 = server_cpu(result.server_pid)
    if cpu0 is not None and cpu1 is not None:
        result.server_cpu = (cpu1[0] - cpu0[0], cpu1[1] - cpu0[1])


def server_cpu(pid: int | None) -> tuple[float, float] | None:
    """CPU seconds (user + system) of process ``pid`` and of its descendants, from ``/proc``."""
    if pid is None or not os.path.exists(f"/proc/{pid}/stat"):
        return None
    tick = os.sysconf("SC_CLK_TCK")
    stats: dict[int, tuple[int, float]] = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        stats[int(entry)] = (int(fields[1]), (int(fields[11]) + int(fields[12])) / tick)
    tree, grew = {pid}, True
    while grew:
        grew = False
        for child, (parent, _) in stats.items():
            if parent in tree and child not in tree:
                tree.add(child)
                grew = True
    main = stats.get(pid, (0, 0.0))[1]
    return main, sum(stats[p][1] for p in tree if p in stats) - main


async def fast_under_slow(url: str, slow_clients: int, duration: float, pid: int | None) -> tuple[Result, Result]:
    result = Result("fast-under-slow", server_pid=pid)
    slow_result = Result("(slow requests)")
    # every slow request distinct: identical ones would share one computation
    slow = asyncio.create_task(
        closed_loop(
            url,
            SLOW_PATH,
            lambda i: slow_request(time_budget_s=5, seed=next(_unique)),
            slow_clients,
            duration,
            slow_result,
        )
    )
    await asyncio.sleep(0.5)  # let the slow ones occupy the pool first
    await closed_loop(url, "/v1/analyze", lambda i: analyze_body(i, unique=True), 1, duration - 0.5, result)
    await slow
    return result, slow_result


async def run(
    url: str, scenarios: list[str], clients: int, duration: float, slow_clients: int, pid: int | None
) -> list[Result]:
    results = []
    for name in scenarios:
        if name == "fast-under-slow":
            results.extend(await fast_under_slow(url, slow_clients, duration, pid))
            continue
        path, make = {
            "analyze-cached": ("/v1/analyze", lambda i: analyze_body(i, unique=False)),
            "analyze-uncached": ("/v1/analyze", lambda i: analyze_body(i, unique=True)),
            "bounds-uncached": ("/v1/bounds", lambda i: analyze_body(i, unique=True)),
            "simulate-uncached": ("/v1/simulate", simulate_body),
        }[name]
        result = Result(name, server_pid=pid)
        await closed_loop(url, path, make, clients, duration, result)
        results.append(result)
    return results


def reference_server(commit: str, workers: int) -> LiveServer:
    """A :class:`LiveServer` running ``kfio serve`` of ``commit`` (with this interpreter and its packages).

    Commits since the layout change hold the package ``kfio`` (:func:`_reference.reference_tree`);
    earlier ones the top-level ``analyzer`` and ``service``, which are unpacked as they were and run
    from their own folder, so that nothing of this checkout is imported.
    """
    import subprocess
    import tempfile

    pyproject = subprocess.run(
        ["git", "show", f"{commit}:pyproject.toml"], cwd=ROOT, check=True, capture_output=True, text=True
    ).stdout
    if "package-dir" in pyproject:
        tree, module = reference_tree(commit), "kfio.service.cli"
    else:
        tree, module = Path(tempfile.gettempdir()) / f"kfio-reference-{commit}-flat", "service.cli"
        if not (tree / "service" / "__init__.py").exists():
            unpack(commit, tree)
    # one BLAS thread per worker, as the current service sets for its own workers
    env = {"PYTHONPATH": str(tree), "OPENBLAS_NUM_THREADS": "1"}
    return LiveServer(command=[sys.executable, "-m", module, "serve"], env=env, workers=workers, cwd=tree)


def ratio_rows(now: list[Result], before: list[Result]) -> list[str]:
    """Markdown rows: requests per second and p50 of each scenario, now against the reference."""
    rows = []
    for a, b in zip(now, before):
        if not a.latencies or not b.latencies or not a.elapsed or not b.elapsed:
            continue
        rps_a, rps_b = len(a.latencies) / a.elapsed, len(b.latencies) / b.elapsed
        p50_a, p50_b = (1000 * sorted(r.latencies)[len(r.latencies) // 2] for r in (a, b))
        rows.append(
            f"| {a.scenario} | {rps_a:.1f} | {rps_b:.1f} | {rps_a / rps_b:.1f}x | {p50_a:.1f} | {p50_b:.1f} | "
            f"{p50_b / p50_a:.1f}x |"
        )
    return rows


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
    p.add_argument(
        "--reference",
        default=SERVICE_REFERENCE,
        help=f"commit whose server runs the same scenarios after this one (default {SERVICE_REFERENCE}; 'none': skip)",
    )
    args = p.parse_args(argv)
    server_cpus, client_cpus = _cpu_split(args.server_cpus, args.client_cpus)

    client_cpu: list[float] = []  # per run of the scenarios: this server's, then the reference's

    def go(url: str, pid: int | None) -> list[Result]:
        t0 = time.process_time()
        try:
            return asyncio.run(run(url, args.scenarios, args.clients, args.duration, args.slow, pid))
        finally:
            client_cpu.append(time.process_time() - t0)

    def started(server: LiveServer) -> list[Result]:
        # The server, its forkserver and every worker inherit the affinity of the process that starts them:
        # pin ourselves to the server's CPUs, start it, then move the load generator to its own CPUs.
        os.sched_setaffinity(0, server_cpus)
        with server:
            os.sched_setaffinity(0, client_cpus)
            return go(server.url, server.proc.pid if server.proc is not None else None)

    reference: list[Result] = []
    if args.url:
        os.sched_setaffinity(0, client_cpus)
        results = go(args.url, None)
        workers = "?"
    else:
        results = started(LiveServer(workers=args.workers))
        if args.reference.lower() != "none":
            reference = started(reference_server(args.reference, args.workers))
        workers = str(args.workers)
    print(
        f"kfio service on 127.0.0.1, {workers} workers, {os.cpu_count()} cores, Python {platform.python_version()}; "
        f"{args.clients} clients x {args.duration:g} s per scenario ({args.slow} slow clients in fast-under-slow); "
        f"server pinned to CPUs {sorted(server_cpus)}, load generator to CPUs {sorted(client_cpus)} "
        f"(os.sched_setaffinity; load average at the end {os.getloadavg()[0]:.1f})\n"
    )
    print(
        f"load generator: {1000 * client_cpu[0] / max(1, sum(len(r.latencies) for r in results)):.2f} ms CPU per request\n"
    )
    print(TABLE_HEAD)
    for r in results:
        print(r.row())
    if reference:
        print(f"\nthe server of {args.reference}, same scenarios, same pinning:\n")
        print(TABLE_HEAD)
        for r in reference:
            print(r.row())
        print(f"\nsame run, now against {args.reference}:\n")
        print(
            f"| scenario | req/s now | req/s {args.reference} | ratio | p50 ms now | p50 ms {args.reference} | ratio |"
        )
        print("|---|---:|---:|---:|---:|---:|---:|")
        for row in ratio_rows(results, reference):
            print(row)
    return 0


if __name__ == "__main__":
    sys.exit(main())
