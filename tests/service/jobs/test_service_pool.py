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
from kfio.service.pool import PoolBusy, PoolTimeout, WorkerCrashed, WorkerOutOfMemory, WorkerPool
from kfio.service.settings import Settings

from support.live_server import JSON_HEADERS, SLOW_PATH, slow_request

HERE = __name__  # the workers import this module to find the runners below


def echo(value: object, budget_s: float) -> object:
    return value


def sleeper(seconds: float, budget_s: float) -> float:
    time.sleep(seconds)  # never checks its budget: only a kill stops it
    return seconds


def crasher(code: int, budget_s: float) -> None:
    os._exit(code)


def aborter(_: object, budget_s: float) -> None:
    os.abort()  # what FLINT does when an allocation fails


def allocator(n_bytes: int, budget_s: float) -> tuple[str, int]:
    try:
        return ("ok", len(bytearray(n_bytes)))
    except MemoryError:
        return ("problem", -1)


def pool(size: int, runner: str, **kw: object) -> WorkerPool:
    # the same preload as the app: whichever pool starts the (shared) forkserver decides it
    return WorkerPool(size, f"{HERE}:{runner}", preload=PRELOAD, **kw)  # type: ignore[arg-type]


def test_deadline_kills_the_stuck_worker_and_replaces_it() -> None:
    async def scenario() -> None:
        p = pool(1, "sleeper", kill_grace_s=0.1)
        await p.start()
        try:
            (stuck,) = p._all
            with pytest.raises(PoolTimeout):  # a 60 s sleep cannot have finished: the deadline fired
                await p.run((60.0,), budget_s=0.5)
            await asyncio.to_thread(stuck.process.join, 30)
            assert not stuck.process.is_alive()  # killed, not left running
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


def test_a_worker_at_its_memory_limit_is_reported_and_retired() -> None:
    async def scenario() -> None:
        p = pool(1, "allocator", memory_bytes=1 << 30, retire=lambda v: v[0] == "problem")
        await p.start()
        try:
            assert await p.run((1 << 20,), budget_s=30) == ("ok", 1 << 20)
            assert await p.run((2 << 30,), budget_s=30) == ("problem", -1)  # 2 GiB past a 1 GiB limit
            for _ in range(600):  # bounded by count: the retired worker is replaced in the background
                if p.stats()["replaced"] == 1 and p.ready:
                    break
                await asyncio.sleep(0.05)
            assert p.stats()["replaced"] == 1
            assert await p.run((1 << 20,), budget_s=30) == ("ok", 1 << 20)
        finally:
            await p.close()
        q = pool(1, "aborter", memory_bytes=1 << 30)
        await q.start()
        try:
            with pytest.raises(WorkerOutOfMemory, match="signal 6.*memory limit of 1024 MiB"):
                await q.run((None,), budget_s=30)
        finally:
            await q.close()

    asyncio.run(scenario())


@pytest.mark.slow
def test_waiting_is_bounded_in_count_and_in_time() -> None:
    async def scenario() -> None:
        p = pool(1, "sleeper", max_waiting=1)  # the busy task sleeps 5 s, the waiter's budget is 0.3 s
        await p.start()
        try:
            busy = asyncio.create_task(p.run((5.0,), budget_s=30))
            await asyncio.sleep(0.1)
            waiting = asyncio.create_task(p.run((0.0,), budget_s=0.3))  # waits, then gives up
            await asyncio.sleep(0.05)
            with pytest.raises(PoolBusy, match="already waiting"):  # the queue (1) is full
                await p.run((0.0,), budget_s=10)
            with pytest.raises(PoolBusy, match="no worker became free"):
                await waiting
            assert not busy.done()  # it gave up on its own budget while the worker was still busy
            assert await busy == 5.0
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
        for _ in range(1200):  # bounded by count
            if not client_not_ready(c):
                break
            time.sleep(0.05)
        yield c


def client_not_ready(c: TestClient) -> bool:
    return c.get("/readyz").status_code != 200


@pytest.mark.slow
def test_past_its_budget_a_request_gets_504_and_the_service_recovers(client: TestClient) -> None:
    r = client.post(SLOW_PATH, content=slow_request(time_budget_s=1), headers=JSON_HEADERS)
    assert r.status_code == 504, r.text  # the request takes minutes: only the budget ended it
    assert r.headers["content-type"] == "application/problem+json"
    assert r.json()["type"] == "urn:kfio:problem:budget-exceeded"
    ok = client.post("/v1/analyze", json=REQUEST_EXAMPLES["seed002-2x2"]["value"])
    assert ok.status_code == 200, ok.text
    # budget hit in the worker, or the worker killed and replaced in the background: whole again
    for _ in range(1200):  # bounded by count: a replacement may take seconds on a loaded machine
        pool = client.get("/readyz").json()["pool"]
        if pool["alive"] == pool["size"] and pool["busy"] == 0:
            break
        time.sleep(0.05)
    assert pool["alive"] == pool["size"] and pool["busy"] == 0, pool


@pytest.mark.slow
def test_healthz_answers_while_every_worker_is_busy(client: TestClient) -> None:
    results: list[int] = []
    slow = [slow_request(time_budget_s=10, seed=s) for s in (11, 12)]  # distinct: no shared computation
    threads = [
        threading.Thread(
            target=lambda b=b: results.append(client.post(SLOW_PATH, content=b, headers=JSON_HEADERS).status_code)
        )
        for b in slow
    ]
    for t in threads:
        t.start()
    try:
        for _ in range(1200):  # bounded by count: a hang guard
            if client.get("/readyz").json()["pool"]["busy"] == 2:
                break
            time.sleep(0.02)
        assert client.get("/readyz").json()["pool"]["busy"] == 2, "the slow requests never occupied the pool"
        for _ in range(20):
            assert client.get("/healthz").status_code == 200
        assert client.get("/readyz").json()["pool"]["busy"] == 2  # every answer came while both were busy
    finally:
        for t in threads:
            t.join(timeout=60)
    assert results == [504, 504]


def test_a_large_answer_is_read_whole_when_the_loop_left_the_pipe_non_blocking() -> None:
    # uvloop's add_reader leaves the fd non-blocking; a 1 MB answer then arrives in pieces and a
    # non-blocking recv() raised BlockingIOError, which the pool reported as a crashed worker
    import multiprocessing

    from kfio.service.pool import _readable

    reader, writer = multiprocessing.Pipe(duplex=False)
    payload = b"x" * (1 << 20)

    def send() -> None:
        try:
            writer.send_bytes(payload)
        except OSError:  # the reader gave up (the test failed)
            pass

    async def go() -> bytes:
        os.set_blocking(reader.fileno(), False)  # what such a loop does
        waiting = asyncio.ensure_future(_readable(reader, 30))
        await asyncio.sleep(0)  # the wait has begun (nothing was written yet): it is registered with the loop
        sender = threading.Thread(target=send)
        sender.start()
        try:
            await waiting
            assert os.get_blocking(reader.fileno())
            return reader.recv_bytes()
        finally:
            reader.close()  # a writer still blocked on a full pipe gets EPIPE instead of waiting
            sender.join(timeout=30)

    assert asyncio.run(go()) == payload
