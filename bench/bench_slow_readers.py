"""Server memory under rounds of slow readers of the ReDoc bundle, now and on an earlier commit (loopback only).

Three rounds of 300 clients that request the ReDoc bundle
(``/docs-assets/redoc.standalone.js``, about 1 MiB) and read 1 byte a second
took the server from 62 to 328-392 MiB resident, kept after they left.

For each server (this checkout, then ``--reference``, default ``e31a5da``,
unless ``--reference none``) it starts ``kfio serve`` with one worker, and
runs ``--rounds`` (3) rounds of ``--clients`` (300) connections.  Each
client's socket has a 4 KiB receive buffer (so the kernel does not take the
response off the server's hands), sends the request, then reads one byte a
second for ``--round-s`` seconds (45), then closes.  It samples the server
process's resident memory (``VmRSS``; the workers are other processes) at
the start, at the peak of each round, and ``--settle-s`` seconds (5) after
each round's clients left, and counts the connections the server closed on
the clients (a read that returned end of file or an error, during the round
or when the client drains its socket at the end).  Every socket
has a timeout; everything stops by itself.

On a Linux loopback the kernel's send buffer of each connection grows to
about 4 MiB (``net.ipv4.tcp_wmem``) and takes the whole 1 MiB bundle off the
server's hands, so this reproducer may show no growth at all.  ``--target
sweep-result`` reads a larger answer instead: the server first runs a sweep
of ``--sweep-points`` (40,000) scalar analyses as a job, and the slow readers
(``--clients``, use about 50) then request its result (about 14 MB), of
which the kernel takes 4 MiB and the server process holds the rest unless it
sends in pieces.

Usage::

    python bench/bench_slow_readers.py
    python bench/bench_slow_readers.py --clients 100 --round-s 20 --reference none
    python bench/bench_slow_readers.py --target sweep-result --clients 50
"""

from __future__ import annotations

import argparse
import json
import socket
import sys
import time
from pathlib import Path
from typing import Any

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_service import reference_server  # noqa: E402

from support.hostile import rss_mb  # noqa: E402
from support.live_server import JSON_HEADERS, LiveServer  # noqa: E402

#: The reference: the service before slow readers were bounded.
SLOW_READERS_REFERENCE = "e31a5da"
PATH = "/docs-assets/redoc.standalone.js"


def open_reader(port: int, path: str = PATH) -> socket.socket:
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # before connect: the window stays small
    s.settimeout(10)
    s.connect(("127.0.0.1", port))
    s.sendall(f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n".encode())
    s.setblocking(False)
    return s


def one_round(port: int, pid: int, clients: int, round_s: float, path: str) -> tuple[float, int]:
    """Peak RSS (MiB) while ``clients`` slow readers of ``path`` are connected, and how many the server cut off."""
    readers = [open_reader(port, path) for _ in range(clients)]
    cut = 0
    alive = list(readers)
    peak = rss_mb(pid)
    end = time.monotonic() + round_s
    while time.monotonic() < end and alive:
        still = []
        for s in alive:
            try:
                if s.recv(1) == b"":
                    cut += 1
                    continue
            except BlockingIOError:
                pass
            except OSError:
                cut += 1
                continue
            still.append(s)
        alive = still
        peak = max(peak, rss_mb(pid))
        time.sleep(1.0)
    cut += sum(1 for s in alive if ended(s))
    for s in readers:
        s.close()
    return peak, cut


def ended(s: socket.socket) -> bool:
    """Drain what the socket holds: True if the server ended the connection (end of file or reset)."""
    try:
        while s.recv(1 << 16):
            pass
    except BlockingIOError:
        return False  # still open: it would send more
    except OSError:
        return True
    return True


def sweep_result_path(url: str, points: int) -> str:
    """Run a sweep of ``points`` scalar analyses as a job; the path of its result."""
    body = {
        "command": "analyze",
        "base": {"system": {"A": [[2]], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": 0.5}},
        "axes": [{"pointer": "/channel/arrival_probability", "from": "1/10", "to": "9/10", "num": points}],
        "combine": "grid",
    }
    r = httpx.post(f"{url}/v1/sweeps", content=json.dumps(body), headers=JSON_HEADERS, timeout=60)
    r.raise_for_status()
    location = r.headers["location"]
    deadline = time.monotonic() + 600
    while httpx.get(url + location, timeout=30).json()["status"] != "done":
        if time.monotonic() > deadline:
            raise RuntimeError("the sweep did not finish within 600 s")
        time.sleep(1.0)
    size = len(httpx.get(url + location + "/result", timeout=60).content)
    print(f"(sweep result: {size / 2**20:.1f} MiB)", flush=True)
    return location + "/result"


def measure(server: LiveServer, args: argparse.Namespace) -> dict[str, Any]:
    with server:
        assert server.proc is not None
        pid = server.proc.pid
        path = PATH if args.target == "redoc" else sweep_result_path(server.url, args.sweep_points)
        time.sleep(args.settle_s)
        start = rss_mb(pid)
        rounds = []
        for _ in range(args.rounds):
            peak, cut = one_round(server.port, pid, args.clients, args.round_s, path)
            time.sleep(args.settle_s)
            rounds.append({"peak": peak, "after": rss_mb(pid), "cut": cut})
        return {"start": start, "rounds": rounds}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--clients", type=int, default=300)
    parser.add_argument("--round-s", type=float, default=45.0, help="seconds each round's clients stay")
    parser.add_argument("--settle-s", type=float, default=5.0)
    parser.add_argument("--reference", default=SLOW_READERS_REFERENCE, help="commit to compare with, or none")
    parser.add_argument("--target", choices=["redoc", "sweep-result"], default="redoc", help="what the readers request")
    parser.add_argument("--sweep-points", type=int, default=40_000, help="points of the sweep whose result is read")
    args = parser.parse_args()
    env = {"KFIO_JOB_WORKERS": "1", "KFIO_LANE_WORKERS": "0"}
    servers = [("now", LiveServer(env=env, workers=1))]
    if args.reference != "none":
        servers.append((args.reference, reference_server(args.reference, 1)))
    what = PATH if args.target == "redoc" else f"a {args.sweep_points}-point sweep's result"
    print(f"{args.rounds} rounds x {args.clients} clients reading 1 byte/s of {what} for {args.round_s:g} s")
    print("| server | RSS at start MiB | per round: peak / after they left MiB (connections cut) | last - start MiB |")
    print("|---|---:|---|---:|")
    for name, server in servers:
        result = measure(server, args)
        rounds = ", ".join(f"{r['peak']:.0f} / {r['after']:.0f} ({r['cut']})" for r in result["rounds"])
        growth = result["rounds"][-1]["after"] - result["start"]
        print(f"| {name} | {result['start']:.0f} | {rounds} | {growth:+.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
