"""A ``KFIO_DASK_SCHEDULER`` that cannot work is the server's fault, not the client's.

Reproducer: with the setting naming a scheduler that is down (or with Dask
missing), every sweep got 422 "invalid input at /engine", ``in: body``.  Now:
503 ``server-misconfigured`` naming the setting, and ``kfio serve`` checks the
setting at start (exit 6).
"""

from __future__ import annotations

import importlib.util
import json
import socket
import time

import pytest
from fastapi.testclient import TestClient

from kfio.service import exitcodes, sweep_jobs
from kfio.service.app import create_app
from kfio.service.cli import main
from kfio.service.settings import Settings

BASE = {
    "system": {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]], "Q": [[20, 0], [0, 20]], "R": [[2.5]]},
    "channel": {"model": "bernoulli", "arrival_probability": 0.5},
}
SWEEP = {"base": BASE, "axes": [{"pointer": "/channel/arrival_probability", "values": ["1/2", "9/10"]}]}
MISCONFIGURED = "urn:kfio:problem:server-misconfigured"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def started(settings: Settings) -> TestClient:
    client = TestClient(create_app(settings))
    client.__enter__()
    deadline = time.monotonic() + 60
    while client.get("/readyz").status_code != 200:
        assert time.monotonic() < deadline, "the worker pools did not start"
        time.sleep(0.05)
    return client


def assert_server_fault(problem: dict) -> None:
    assert problem["status"] == 503 and problem["type"] == MISCONFIGURED, problem
    assert "KFIO_DASK_SCHEDULER" in problem["detail"]
    assert "field" not in problem and problem.get("in") != "body"


@pytest.mark.slow
def test_a_scheduler_that_is_down_fails_the_sweep_with_503_server_misconfigured():
    client = started(Settings(workers=1, job_workers=1, dask_scheduler=f"tcp://127.0.0.1:{free_port()}"))
    try:
        r = client.post("/v1/sweeps", content=json.dumps(SWEEP), headers={"content-type": "application/json"})
        assert r.status_code == 202, r.text
        location = r.headers["location"]
        deadline = time.monotonic() + 120
        while (doc := client.get(location).json())["status"] not in ("done", "failed", "cancelled"):
            assert time.monotonic() < deadline, doc
            time.sleep(0.1)
        assert doc["status"] == "failed", doc
        assert_server_fault(doc["problem"])
        result = client.get(location + "/result")
        assert result.status_code == 503 and result.headers["content-type"] == "application/problem+json"
    finally:
        client.__exit__(None, None, None)


def test_without_dask_a_sweep_is_refused_503_at_once(monkeypatch):
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "distributed" else real(name, *a))
    client = started(Settings(workers=1, job_workers=1, dask_scheduler="tcp://127.0.0.1:8786"))
    try:
        r = client.post("/v1/sweeps", content=json.dumps(SWEEP), headers={"content-type": "application/json"})
        assert r.headers["content-type"] == "application/problem+json"
        assert_server_fault(r.json())
        assert "not installed" in r.json()["detail"]
    finally:
        client.__exit__(None, None, None)


@pytest.mark.slow
def test_kfio_serve_checks_the_scheduler_at_start_and_exits_6_naming_the_setting(monkeypatch, capsys):
    monkeypatch.setattr(sweep_jobs, "DASK_CONNECT_TIMEOUT_S", 1.0)
    monkeypatch.setenv("KFIO_DASK_SCHEDULER", f"tcp://127.0.0.1:{free_port()}")
    assert main(["serve", "--port", str(free_port())]) == exitcodes.CANNOT_SERVE
    err = capsys.readouterr().err
    assert "KFIO_DASK_SCHEDULER" in err and "cannot reach the Dask scheduler" in err and "Traceback" not in err
