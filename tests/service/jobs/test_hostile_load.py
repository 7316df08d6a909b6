"""With three validation-heavy sweeps in flight, the server keeps answering and stops on SIGTERM.

Reproducer: seven sweeps of 100,000 points with a near-singular 40 x 40 ``Q``
(24 KB each) were validated in the server's threads: every client timed out,
and SIGTERM did not stop the server.  Now the server only sizes them; their
points are validated by the job lane's worker.  This test asserts behaviour
with generous timeouts (the failure mode is a hang): ``/healthz`` and a 2x2
analyze answer, the server's resident memory stays under 300 MB, and SIGTERM
ends it within its grace period.  The 1 s figures are measured by
``bench/bench_hostile.py``, not asserted here.
"""

from __future__ import annotations

import signal
import subprocess

import httpx
import pytest

from support.hostile import SMALL, heavy_sweep, rss_mb
from support.live_server import JSON_HEADERS, LiveServer

GRACE_S = 3.0


@pytest.mark.slow
def test_healthz_and_a_small_analyze_answer_while_three_heavy_sweeps_are_in_flight_and_sigterm_stops_it():
    env = {"KFIO_JOB_WORKERS": "1", "KFIO_SHUTDOWN_GRACE_S": str(GRACE_S), "KFIO_MEMORY_MB": "2048"}
    with LiveServer(workers=1, env=env) as server:
        assert server.proc is not None
        with httpx.Client(base_url=server.url, timeout=10) as client:
            locations = []
            for seed in range(3):
                r = client.post("/v1/sweeps", content=heavy_sweep(seed=seed), headers=JSON_HEADERS)
                assert r.status_code == 202, r.text
                locations.append(r.headers["location"])
            assert client.get(locations[0]).json()["status"] in ("queued", "running")
            for i in range(5):
                assert client.get("/healthz").status_code == 200
                body = {**SMALL, "channel": {**SMALL["channel"], "arrival_probability": f"0.{50 + i}"}}
                r = client.post("/v1/analyze", json=body)
                assert r.status_code == 200 and r.json()["verdict"] == "stable", r.text
            # the job lane is validating, not the server: its sweeps are still in flight
            assert [client.get(loc).json()["status"] for loc in locations].count("running") == 1
            assert rss_mb(server.proc.pid) < 300
        server.proc.terminate()
        try:
            code = server.proc.wait(timeout=GRACE_S + 10)  # the grace, plus Uvicorn's and the pools' own stops
        except subprocess.TimeoutExpired:  # pragma: no cover - the failure this test is about
            raise AssertionError(f"SIGTERM did not stop the server:\n{server.log()}") from None
        assert code in (0, -signal.SIGTERM), server.log()  # Uvicorn re-raises the signal once it has stopped
        assert "Application shutdown complete" in server.log()
