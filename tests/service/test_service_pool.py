"""The worker pool under stuck, crashing and excess work, alone and behind the app."""

from __future__ import annotations

import asyncio
import os
import threading
import time
from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient

from kfio.service.api.schemas import REQUEST_EXAMPLES
from kfio.service.app import create_app
from kfio.service.jobs import PRELOAD
from kfio.service.pool import PoolBusy, PoolTimeout, WorkerCrashed, WorkerPool
from kfio.service.settings import Settings

from support.live_server import SLOW_PATH, slow_request

HERE = __name__  # the workers import this module to find the runners below


def echo(value: object, budget_s: float) -> object:
    return value


def sleeper(seconds: float, budget_s: float) -> float:
    time.sleep(seconds)  # never checks its budget: only a kill stops it
    return seconds


def crasher(code: int, budget_s: float) -> None:
    os._exit(code)


def pool(size: int, runner: str, **kw: object) -> WorkerPool:
    # the same preload as the app: whichever pool starts the (shared) forkserver decides it
    return WorkerPool(size, f"{HERE}:{runner}", preload=PRELOAD, **kw)  # type: ignore[arg-type]


def test_deadline_kills_the_stuck_worker_and_replaces_it() -> None:
    async def scenario() -> None:
        p = pool(1, "sleeper", kill_grace_s=0.1)
        await p.start()
        try:
            t0 = time.monotonic()
            with pytest.raises(PoolTimeout):
                await p.run((60.0,), budget_s=0.5)
            assert time.monotonic() - t0 < 1.5  # budget 0.5 s + grace 0.1 s, promptly
            assert await p.run((0.01,), budget_s=10) == 0.01  # the replacement works
            assert p.stats()["replaced"] == 1 and p.stats()["alive"] == 1
        finally:
            await p.close()

    asyncio.run(scenario())


def test_a_crashed_worker_is_reported_and_replaced() -> None:
    async def scenario() -> None:
        p = pool(1, "crasher")
        await p.start()
        try:
            with pytest.raises(WorkerCrashed, match="exit code 3"):
                await p.run((3,), budget_s=10)
            await asyncio.sleep(0)  # let the replacement be scheduled
            assert p.stats()["replaced"] == 1
        finally:
            await p.close()

    asyncio.run(scenario())


def test_waiting_is_bounded_in_count_and_in_time() -> None:
    async def scenario() -> None:
        p = pool(1, "sleeper", max_waiting=1)
        await p.start()
        try:
            busy = asyncio.create_task(p.run((1.0,), budget_s=10))
            await asyncio.sleep(0.1)
            t0 = time.monotonic()
            waiting = asyncio.create_task(p.run((0.0,), budget_s=0.3))  # waits, then gives up
            await asyncio.sleep(0.05)
            with pytest.raises(PoolBusy, match="already waiting"):  # the queue (1) is full
                await p.run((0.0,), budget_s=10)
            with pytest.raises(PoolBusy, match="no worker became free"):
                await waiting
            assert time.monotonic() - t0 < 1.0
            assert await busy == 1.0
        finally:
            await p.close()

    asyncio.run(scenario())


def test_results_come_back_unchanged() -> None:
    async def scenario() -> None:
        p = pool(2, "echo")
        await p.start()
        try:
            values = await asyncio.gather(*(p.run(({"i": i, "b": b"\x00" * 100_000},), budget_s=10) for i in range(6)))
            assert [v["i"] for v in values] == list(range(6)) and p.stats()["completed"] == 6
        finally:
            await p.close()
        assert not p.ready

    asyncio.run(scenario())


# -- behind the app ----------------------------------------------------------


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with TestClient(create_app(Settings(workers=2, time_budget_s=20, kill_grace_s=0.25))) as c:
        deadline = time.monotonic() + 30
        while client_not_ready(c) and time.monotonic() < deadline:
            time.sleep(0.05)
        yield c


def client_not_ready(c: TestClient) -> bool:
    return c.get("/readyz").status_code != 200


def test_past_its_budget_a_request_gets_504_promptly_and_the_service_recovers(client: TestClient) -> None:
    t0 = time.monotonic()
    r = client.post(SLOW_PATH, content=slow_request(time_budget_s=1))
    elapsed = time.monotonic() - t0
    assert r.status_code == 504, r.text
    assert r.headers["content-type"] == "application/problem+json"
    assert r.json()["type"] == "urn:kfio:problem:budget-exceeded"
    assert elapsed < 3.0, elapsed  # budget 1 s + grace 0.25 s + parsing
    ok = client.post("/v1/analyze", json=REQUEST_EXAMPLES["seed002-2x2"]["value"])
    assert ok.status_code == 200, ok.text
    # budget hit in the worker, or the worker killed: whole again once the replacement said "ready" (it
    # starts asynchronously; a warm worker answers the analysis above before it is up, so wait for it)
    deadline = time.monotonic() + 30
    while True:
        pool = client.get("/readyz").json()["pool"]
        if (pool["alive"] == pool["size"] and pool["busy"] == 0) or time.monotonic() > deadline:
            break
        time.sleep(0.02)
    assert pool["alive"] == pool["size"] and pool["busy"] == 0


def test_healthz_stays_fast_while_every_worker_is_busy(client: TestClient) -> None:
    results: list[int] = []
    slow = [slow_request(time_budget_s=4, seed=s) for s in (11, 12)]  # distinct: no shared computation
    threads = [
        threading.Thread(target=lambda b=b: results.append(client.post(SLOW_PATH, content=b).status_code)) for b in slow
    ]
    for t in threads:
        t.start()
    try:
        deadline = time.monotonic() + 3
        while client.get("/readyz").json()["pool"]["busy"] < 2:
            assert time.monotonic() < deadline, "the slow requests never occupied the pool"
            time.sleep(0.02)
        latencies = []
        for _ in range(20):
            t0 = time.perf_counter()
            assert client.get("/healthz").status_code == 200
            latencies.append(time.perf_counter() - t0)
        assert client.get("/readyz").json()["pool"]["busy"] == 2  # still fully busy while measured
        assert max(latencies) < 0.1, latencies
    finally:
        for t in threads:
            t.join(timeout=15)
    assert results == [504, 504]
