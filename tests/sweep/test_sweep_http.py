"""``POST /v1/sweeps`` against a real ``kfio serve``: validated up front, run as a job, polled to its table."""

from __future__ import annotations

import json
import time

import httpx

from kfio.sweep import load_sweep, run_sweep

from support.live_server import LiveServer

BASE = {
    "system": {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]], "Q": [[20, 0], [0, 20]], "R": [[2.5]]},
    "channel": {"model": "bernoulli", "arrival_probability": 0.5},
}
SWEEP = {
    "command": "analyze",
    "base": BASE,
    "axes": [{"pointer": "/channel/arrival_probability", "from": "3/10", "to": "9/10", "num": 25}],
}
JSON = {"Content-Type": "application/json"}


def test_sweep_job_gives_the_cli_table_and_bad_points_are_refused_at_once():
    with LiveServer(workers=1) as server:
        bad = {**SWEEP, "axes": [{"pointer": "/channel/arrival_probability", "values": ["1/2", "3/2"]}]}
        r = httpx.post(f"{server.url}/v1/sweeps", content=json.dumps(bad), headers=JSON, timeout=30)
        assert r.status_code == 422, r.text
        assert "/points/1/channel/arrival_probability" in r.text

        r = httpx.post(f"{server.url}/v1/sweeps", content=json.dumps(SWEEP), headers=JSON, timeout=30)
        assert r.status_code == 202, r.text
        location = r.headers["Location"]
        deadline = time.monotonic() + 120
        while True:
            doc = httpx.get(server.url + location, timeout=30).json()
            if doc["status"] in ("done", "failed", "cancelled") or time.monotonic() > deadline:
                break
            time.sleep(0.2)
        assert doc["status"] == "done", doc
        table = doc["result"]
        assert table["points"] == 25 and table["errors"] == 0
        expected = run_sweep(load_sweep(json.dumps(SWEEP)), engine="serial").records()
        assert table["rows"] == expected
        assert table["columns"][:2] == ["index", "/channel/arrival_probability"]
