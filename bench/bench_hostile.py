"""Hostile sweeps, measured on this checkout and on a reference commit (a benchmark, not a test; loopback only).

Starts ``kfio serve`` of this checkout, then (unless ``--reference none``) of
``--reference`` (default ``13e923d``, the service before its hostile-input limits), each with
one analysis worker and one job worker, and for each prints:

* ``150-axis body``: seconds until ``POST /v1/sweeps`` with 150 axes of
  ``num: 100000`` (12.8 KB) is answered, and its status (capped at
  ``--cap`` seconds: the earlier code built every axis first);
* ``2^14300 points``: the same for 14,300 axes of two values (750 KB; a 500
  before: the message printed the count's 4,305 digits);
* under load (three sweeps of 100,000 points with a near-singular 40 x 40
  ``Q`` posted, each on its own connection): the median and largest latency
  of ``/healthz`` and of a 2x2 analyze (a new arrival probability each time,
  so never cached), the failures among them, and the server's resident
  memory (largest sample);
* ``SIGTERM``: seconds from the signal until the server process is gone
  (capped at ``--cap``; then it is killed).

Usage::

    python bench/bench_hostile.py                  # now, then 13e923d
    python bench/bench_hostile.py --reference none

Every request has a timeout; the figures are wall-clock seconds on this machine.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import threading
import time
from pathlib import Path

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_service import reference_server  # noqa: E402

from support.hostile import SMALL, heavy_sweep, rss_mb, values_sweep, wide_sweep  # noqa: E402
from support.live_server import JSON_HEADERS, LiveServer  # noqa: E402

#: The reference: the service before its hostile-input limits.
HOSTILE_REFERENCE = "13e923d"
ENV = {"KFIO_JOB_WORKERS": "1", "KFIO_SHUTDOWN_GRACE_S": "3"}


def timed_post(url: str, body: bytes, cap: float) -> tuple[float, str]:
    """Seconds until the answer (or the cap) and the status (or ``timeout``)."""
    t0 = time.perf_counter()
    try:
        status = str(httpx.post(url, content=body, headers=JSON_HEADERS, timeout=cap).status_code)
    except httpx.TimeoutException:
        status = "timeout"
    except httpx.TransportError as exc:
        status = type(exc).__name__
    return time.perf_counter() - t0, status


def measure(server: LiveServer, cap: float, samples: int) -> dict[str, str]:
    """The figures of one server (see the module docstring)."""
    assert server.proc is not None
    pid = server.proc.pid
    out: dict[str, str] = {}
    peak = rss_mb(pid)
    for label, body in (("150-axis body", wide_sweep(150)), ("2^14300 points", values_sweep(14_300))):
        seconds, status = timed_post(server.url + "/v1/sweeps", body, cap)
        out[label] = f"{status} in {seconds:.3f} s"
        peak = max(peak, rss_mb(pid))
    out["RSS after them"] = f"{rss_mb(pid):.0f} MB"

    posters = [
        threading.Thread(target=timed_post, args=(server.url + "/v1/sweeps", heavy_sweep(seed=s), cap), daemon=True)
        for s in range(3)
    ]
    for t in posters:
        t.start()
    time.sleep(1.0)  # let them arrive
    health: list[float] = []
    analyze: list[float] = []
    failures = 0
    with httpx.Client(base_url=server.url, timeout=cap) as client:
        for i in range(samples):
            t0 = time.perf_counter()
            try:
                ok = client.get("/healthz").status_code == 200
            except httpx.TransportError:
                ok = False
            health.append(time.perf_counter() - t0)
            body = {**SMALL, "channel": {**SMALL["channel"], "arrival_probability": f"0.{5000 + i}"}}
            t0 = time.perf_counter()
            try:
                ok = client.post("/v1/analyze", json=body).status_code == 200 and ok
            except httpx.TransportError:
                ok = False
            analyze.append(time.perf_counter() - t0)
            failures += not ok
            peak = max(peak, rss_mb(pid))
    out["healthz under load"] = f"median {statistics.median(health) * 1e3:.1f} ms, max {max(health) * 1e3:.1f} ms"
    out["2x2 analyze under load"] = f"median {statistics.median(analyze) * 1e3:.1f} ms, max {max(analyze):.2f} s"
    out["failed of those"] = f"{failures} of {samples}"
    out["server RSS (peak)"] = f"{peak:.0f} MB"

    t0 = time.perf_counter()
    server.proc.terminate()
    try:
        server.proc.wait(timeout=cap)
        out["SIGTERM to exit"] = f"{time.perf_counter() - t0:.2f} s"
    except Exception:  # noqa: BLE001 - subprocess.TimeoutExpired: the failure being measured
        out["SIGTERM to exit"] = f"> {cap:g} s (killed)"
        server.proc.kill()
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reference", default=HOSTILE_REFERENCE, help="earlier commit to compare, or 'none'")
    parser.add_argument("--cap", type=float, default=30.0, help="timeout of each request and of SIGTERM, seconds")
    parser.add_argument("--samples", type=int, default=20, help="healthz and analyze requests under load")
    args = parser.parse_args()

    columns = {}
    with LiveServer(workers=1, env=ENV) as server:
        columns["now"] = measure(server, args.cap, args.samples)
    if args.reference.lower() != "none":
        ref = reference_server(args.reference, 1)
        ref.env.update(ENV)
        with ref:
            columns[args.reference] = measure(ref, args.cap, args.samples)
    names = list(columns)
    print("| figure | " + " | ".join(names) + " |")
    print("|---|" + "---|" * len(names))
    for key in columns["now"]:
        print(f"| {key} | " + " | ".join(columns[n][key] for n in names) + " |")


if __name__ == "__main__":
    main()
