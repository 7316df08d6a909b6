"""``POST /v1/sweeps`` against a real ``kfio serve``: validated up front, run as a job, polled to its table."""

from __future__ import annotations

import json
import time

import httpx
import pytest

from kfio.errors import InvalidInput
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


def _finished(server: LiveServer, location: str) -> dict:
    deadline = time.monotonic() + 120
    while True:
        doc = httpx.get(server.url + location, timeout=30).json()
        if doc["status"] in ("done", "failed", "cancelled") or time.monotonic() > deadline:
            return doc
        time.sleep(0.2)


@pytest.mark.slow
def test_sweep_job_gives_the_cli_table_and_a_bad_point_fails_its_job_naming_it():
    with LiveServer(workers=1) as server:
        bad_shape = {**SWEEP, "axes": [{"pointer": "/channel/nowhere", "values": ["1/2"]}]}
        r = httpx.post(f"{server.url}/v1/sweeps", content=json.dumps(bad_shape), headers=JSON, timeout=30)
        assert r.status_code == 422 and r.json()["field"] == "/axes/0/pointer", r.text

        # the points are validated by the job's worker, not by the server: the job fails with the 422 problem
        bad = {**SWEEP, "axes": [{"pointer": "/channel/arrival_probability", "values": ["1/2", "3/2"]}]}
        r = httpx.post(f"{server.url}/v1/sweeps", content=json.dumps(bad), headers=JSON, timeout=30)
        assert r.status_code == 202, r.text
        doc = _finished(server, r.headers["Location"])
        assert doc["status"] == "failed" and doc["problem"]["status"] == 422, doc
        assert doc["problem"]["field"] == "/points/1/channel/arrival_probability"
        r = httpx.get(server.url + doc["links"]["result"], timeout=30)
        assert r.status_code == 422 and r.json()["field"] == "/points/1/channel/arrival_probability"

        r = httpx.post(f"{server.url}/v1/sweeps", content=json.dumps(SWEEP), headers=JSON, timeout=30)
        assert r.status_code == 202, r.text
        doc = _finished(server, r.headers["Location"])
        assert doc["status"] == "done", doc
        table = doc["result"]
        assert table["points"] == 25 and table["errors"] == 0
        expected = run_sweep(load_sweep(json.dumps(SWEEP)), engine="serial").records()
        assert table["rows"] == expected
        assert table["columns"][:2] == ["index", "axis:/channel/arrival_probability"]


def test_the_route_refuses_at_submit_what_its_schema_refuses_and_leaves_requests_to_the_worker() -> None:
    """The route's schema (``SWEEP_ROUTE_SCHEMA``): ``base`` and each of ``requests`` must be objects, checked at
    once; their content is each point's, validated by the job's worker (a schemathesis negative case found a
    sweep accepted whose requests broke the strict request schema the route used to advertise)."""
    from kfio.service.api.sweeps import SWEEP_ROUTE_SCHEMA

    assert SWEEP_ROUTE_SCHEMA["properties"]["base"]["type"] == "object"
    assert SWEEP_ROUTE_SCHEMA["properties"]["requests"]["items"] == {"type": "object"}
    for body, field in (
        ({"base": 5}, "/base"),
        ({"requests": [{}, 5]}, "/requests/1"),
        ({"requests": []}, "/requests"),
    ):
        with pytest.raises(InvalidInput) as err:
            load_sweep(json.dumps(body))
        assert err.value.field == field
