"""The service under hostile requests: the event loop never parses, media types, budgets, memory.

No assertion here depends on the clock: "the loop was not blocked" is shown by
``/healthz`` answering while two body parses are provably still running (they
are held in their threads until it has answered).
"""

from __future__ import annotations

import asyncio
import json
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

import pytest
from fastapi.testclient import TestClient

from kfio.service import dispatch
from kfio.service.app import create_app
from kfio.service.settings import Settings

from support.live_server import JSON_HEADERS, SLOW_PATH, memory_request, slow_request

PROBLEM = "application/problem+json"
SCALAR = {"system": {"A": [[2]], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": 0.5}}


def wait_for(predicate, what: str) -> None:  # noqa: ANN001
    for _ in range(1200):  # bounded by count: a hang guard, not a timing
        if predicate():
            return
        time.sleep(0.05)
    raise AssertionError(f"never happened: {what}")


@contextmanager
def started(settings: Settings) -> Iterator[TestClient]:
    with TestClient(create_app(settings)) as c:
        wait_for(lambda: c.get("/readyz").status_code == 200, "the pool started")
        yield c


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with started(Settings(workers=1, time_budget_s=20)) as c:
        yield c


@pytest.mark.slow
def test_big_bodies_are_parsed_off_the_event_loop(client: TestClient, monkeypatch: pytest.MonkeyPatch) -> None:
    real = dispatch.load_json
    gate = threading.Event()
    entered = threading.Semaphore(0)
    seen: list[tuple[object, str]] = []

    def held_load_json(body: bytes) -> object:
        seen.append((asyncio._get_running_loop(), threading.current_thread().name))
        entered.release()
        gate.wait(timeout=120)
        return real(body)

    monkeypatch.setattr(dispatch, "load_json", held_load_json)
    big = json.dumps(
        {**SCALAR, "system": {"A": [[1] * 500_000], "C": [[1]]}}, separators=(",", ":")
    ).encode()  # ~1 MiB, invalid
    assert 1_000_000 < len(big) <= 1 << 20
    statuses: list[int] = []
    clients = [
        threading.Thread(
            target=lambda: statuses.append(client.post(SLOW_PATH, content=big, headers=JSON_HEADERS).status_code)
        )
        for _ in range(2)
    ]
    for t in clients:
        t.start()
    try:
        for _ in range(2):
            assert entered.acquire(timeout=120), "the parses never started"
        # both parses are running now and cannot finish until the gate opens
        for _ in range(5):
            assert client.get("/healthz").status_code == 200
        assert not gate.is_set()
    finally:
        gate.set()
        for t in clients:
            t.join(timeout=120)
    assert statuses == [422, 422]
    assert len(seen) == 2
    assert all(loop is None and name.startswith("kfio-parse") for loop, name in seen), seen


@pytest.mark.parametrize(
    "content_type", [None, "text/plain", "application/x-www-form-urlencoded", "multipart/form-data; boundary=x"]
)
def test_non_json_media_types_are_415(client: TestClient, content_type: str | None) -> None:
    headers = {"Content-Type": content_type} if content_type else {}
    r = client.post("/v1/analyze", content=json.dumps(SCALAR), headers=headers)
    assert r.status_code == 415 and r.headers["content-type"] == PROBLEM
    assert r.json()["type"] == "urn:kfio:problem:unsupported-media-type"
    assert r.json()["field"] == "Content-Type" and "application/json" in r.json()["detail"]


@pytest.mark.parametrize("content_type", ["application/json; charset=utf-8", "APPLICATION/JSON"])
def test_json_media_types_are_accepted(client: TestClient, content_type: str) -> None:
    r = client.post("/v1/analyze", content=json.dumps(SCALAR), headers={"Content-Type": content_type})
    assert r.status_code == 200, r.text


@pytest.mark.parametrize("tiny", ["1e-199", 1e-199, 0.001])
def test_a_budget_too_small_to_do_anything_is_422(client: TestClient, tiny: object) -> None:
    r = client.post("/v1/analyze", json={**SCALAR, "options": {"time_budget_s": tiny}})
    assert r.status_code == 422, r.text
    assert "retry-after" not in r.headers
    assert r.json()["field"] == "/options/time_budget_s" and "0.01" in r.json()["rule"]


@pytest.mark.slow
def test_validation_comes_before_the_busy_answer() -> None:
    # no cheap lane: its reserved worker would answer the small valid request (tests/service/jobs/test_lanes.py)
    with started(Settings(workers=1, max_queue=0, time_budget_s=20, lane_workers=0)) as c:
        hold = threading.Thread(
            target=lambda: c.post(SLOW_PATH, content=slow_request(time_budget_s=12, seed=61), headers=JSON_HEADERS)
        )
        hold.start()
        try:
            wait_for(lambda: c.get("/readyz").json().get("pool", {}).get("busy") == 1, "the worker is busy")
            invalid = c.post(
                "/v1/analyze", json={**SCALAR, "channel": {"model": "bernoulli", "arrival_probability": 1.5}}
            )
            valid = c.post("/v1/analyze", json=SCALAR)
            still_busy = c.get("/readyz").json()["pool"]["busy"] == 1
        finally:
            hold.join(timeout=60)
        assert still_busy  # both answers came while the only worker was provably busy
        assert invalid.status_code == 422 and "retry-after" not in invalid.headers, invalid.text
        assert invalid.json()["field"] == "/channel/arrival_probability"
        assert valid.status_code == 503 and valid.headers["retry-after"] == "1"


def test_a_worker_out_of_memory_gives_422_and_is_replaced() -> None:
    # a worker maps about 440 MiB after its imports; Monte Carlo at the size limits needs far more
    with started(Settings(workers=1, memory_mb=600, time_budget_s=30)) as c:
        r = c.post(SLOW_PATH, content=memory_request(time_budget_s=20, seed=62), headers=JSON_HEADERS)
        assert r.status_code == 422 and r.headers["content-type"] == PROBLEM, r.text
        assert r.json()["type"] == "urn:kfio:problem:memory-exceeded"
        wait_for(lambda: c.get("/readyz").status_code == 200, "the worker was replaced")
        assert c.get("/readyz").json()["pool"]["replaced"] == 1
        assert c.post("/v1/analyze", json=SCALAR).status_code == 200
