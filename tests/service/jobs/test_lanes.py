"""Cheap work is not stuck behind heavy work (the cheap lane).

Reproducer: with the default 2 workers and four 8-second loop requests in
flight, a 1x1 analyze waited 7.7 s (p50).  The rule (which request is cheap)
and the routing (which worker a task gets) are checked functionally here;
the latencies are measured by ``bench/bench_mixed_load.py``.
"""

from __future__ import annotations

import asyncio
import json
import os
import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient

from kfio.service.dispatch import request_key
from kfio.service.jobs import PRELOAD
from kfio.service.lanes import MAX_BODY_BYTES, MAX_MARKOV_ORDER, MAX_STATES, is_cheap
from kfio.service.pool import WorkerPool
from kfio.service.settings import Settings

from support.app_client import ready_client
from support.live_server import JSON_HEADERS, SLOW_PATH, slow_request

HERE = __name__  # the workers import this module to find the runner below


def whoami(seconds: float, budget_s: float) -> int:
    """Sleep (never checking the budget: only a kill stops it), then say which process ran the task."""
    time.sleep(seconds)
    return os.getpid()


def analyze(n: int = 1, channel: dict[str, Any] | None = None, **options: Any) -> dict[str, Any]:
    eye = [[1 if i == j else 0 for j in range(n)] for i in range(n)]
    tree: dict[str, Any] = {
        "system": {"A": [[2 if i == j else 0 for j in range(n)] for i in range(n)], "C": eye},
        "channel": channel or {"model": "bernoulli", "arrival_probability": 0.9},
    }
    if options:
        tree["options"] = {"analyze": options}
    return tree


def markov(order: int) -> dict[str, Any]:
    histories = [format(k, f"0{order}b") for k in range(2**order)] if order else [""]
    return {"model": "markov", "order": order, "arrival_probability": {h: 0.5 for h in histories}}


def cheap(command: str, tree: Any) -> bool:
    return is_cheap(command, tree, len(json.dumps(tree)))


def test_small_analyze_requests_are_cheap_and_everything_else_is_not() -> None:
    assert cheap("analyze", analyze(1))
    assert cheap("analyze", analyze(MAX_STATES))
    assert not cheap("analyze", analyze(MAX_STATES + 1))
    for command in ("bounds", "simulate", "loop", "plot-region", "sweep"):
        assert not cheap(command, analyze(1)), command
    assert cheap("analyze", analyze(2, markov(MAX_MARKOV_ORDER)))
    assert not cheap("analyze", analyze(2, markov(MAX_MARKOV_ORDER + 1)))
    per_sensor = {"model": "per_sensor", "channels": {"a": markov(1), "b": {"model": "bernoulli"}}}
    assert cheap("analyze", analyze(2, per_sensor))
    deep = {"model": "per_sensor", "channels": {"a": markov(MAX_MARKOV_ORDER + 1)}}
    assert not cheap("analyze", analyze(2, deep))
    assert not cheap("analyze", analyze(1, ge_grid=11)) and not cheap("analyze", analyze(1, critical_parameter="/x"))
    assert cheap("analyze", analyze(1, ge_plot_points=3))  # an option outside the costly ones
    long_digits = analyze(1)
    long_digits["system"]["A"] = [["1" + "0" * MAX_BODY_BYTES]]
    assert not cheap("analyze", long_digits)  # the body bounds the digits
    for malformed in (None, [], {"system": "x"}, {"system": {"A": 3}}, {"system": {"A": [[1]]}, "channel": 5}):
        assert not cheap("analyze", malformed), malformed
    assert not cheap("analyze", analyze(1, markov(1) | {"order": True}))


def test_the_dispatcher_marks_a_request_cheap_from_its_body() -> None:
    small = json.dumps(analyze(1)).encode()
    assert request_key("analyze", small, {})[2] is True
    assert request_key("bounds", small, {})[2] is False
    assert request_key("analyze", json.dumps(analyze(MAX_STATES + 1)).encode(), {})[2] is False


def pool(**kw: Any) -> WorkerPool:
    return WorkerPool(1, f"{HERE}:whoami", preload=PRELOAD, reserved=1, **kw)


def pids(p: WorkerPool) -> tuple[int, int]:
    (regular,) = [w.process.pid for w in p._all if not w.reserved]
    (spare,) = [w.process.pid for w in p._all if w.reserved]
    return regular, spare


@pytest.mark.slow  # a pool of its own: the forkserver's imports
def test_a_cheap_task_takes_a_free_regular_worker_first() -> None:
    async def scenario() -> None:
        p = pool()
        await p.start()
        try:
            regular, _ = pids(p)
            assert await p.run((0.0,), 10, cheap=True) == regular
            assert p.stats()["reserved"] == p.stats()["reserved_alive"] == p.stats()["alive"] == 1
        finally:
            await p.close()

    asyncio.run(scenario())


@pytest.mark.slow  # a pool of its own: the forkserver's imports
def test_with_every_regular_worker_busy_a_cheap_task_runs_on_the_reserved_one_and_others_wait() -> None:
    async def scenario() -> None:
        p = pool()
        await p.start()
        try:
            regular, spare = pids(p)
            heavy = asyncio.create_task(p.run((3.0,), 30))
            while p.stats()["busy"] < 1:
                await asyncio.sleep(0.01)
            assert await p.run((0.0,), 10, cheap=True) == spare
            assert not heavy.done()  # answered while the heavy task still holds the regular worker
            other = asyncio.create_task(p.run((0.0,), 30))  # not cheap: it never takes the reserved worker
            await asyncio.sleep(0.2)
            assert not other.done() and p._spare.qsize() == 1
            assert await heavy == regular and await other == regular
        finally:
            await p.close()

    asyncio.run(scenario())


@pytest.mark.slow  # a pool of its own: the forkserver's imports
def test_a_cheap_task_that_outlasts_the_lane_budget_moves_to_a_regular_worker() -> None:
    async def scenario() -> None:
        p = pool(reserved_budget_s=0.3)
        await p.start()
        try:
            regular, spare = pids(p)
            short = asyncio.create_task(p.run((1.0,), 30))
            while p.stats()["busy"] < 1:
                await asyncio.sleep(0.01)
            assert await p.run((1.5,), 30, cheap=True) == regular  # misjudged as cheap: killed there, run here
            assert await short == regular
            stats = p.stats()
            assert stats["moved"] == 1 and stats["replaced"] == 1
            while p._spare.qsize() < 1:  # the lane got a fresh worker
                await asyncio.sleep(0.01)
            assert pids(p)[1] != spare
        finally:
            await p.close()

    asyncio.run(scenario())


@pytest.mark.slow  # a pool of its own: the forkserver's imports
def test_without_reserved_workers_a_cheap_task_waits_for_a_regular_one() -> None:
    async def scenario() -> None:
        p = WorkerPool(1, f"{HERE}:whoami", preload=PRELOAD, reserved=0)
        await p.start()
        try:
            heavy = asyncio.create_task(p.run((1.0,), 30))
            while p.stats()["busy"] < 1:
                await asyncio.sleep(0.01)
            await p.run((0.0,), 30, cheap=True)
            assert heavy.done()  # it could only run once the heavy task had finished
        finally:
            await p.close()

    asyncio.run(scenario())


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    settings = Settings(workers=1, lane_workers=1, job_workers=1, time_budget_s=30, cache_entries=0)
    with ready_client(settings) as c:
        yield c


@pytest.mark.slow
def test_a_small_analyze_is_answered_while_a_slow_request_holds_the_only_regular_worker(client: TestClient) -> None:
    done = threading.Event()

    def slow() -> None:
        client.post(SLOW_PATH, content=slow_request(time_budget_s=8), headers=JSON_HEADERS)
        done.set()

    thread = threading.Thread(target=slow, daemon=True)
    thread.start()
    deadline = time.monotonic() + 30
    while client.get("/readyz").json()["pool"]["busy"] < 1:
        assert time.monotonic() < deadline
        time.sleep(0.05)
    small = client.post("/v1/analyze", content=json.dumps(analyze(1)), headers=JSON_HEADERS)
    assert small.status_code == 200 and small.json()["verdict"] == "stable"
    assert not done.is_set()  # the slow request is still running: the small one did not wait for it
    bounds = json.dumps({**analyze(1), "system": {"A": [[2]], "C": [[1]], "Q": [[1]], "R": [[1]]}})
    r = client.post("/v1/bounds", content=bounds, headers=JSON_HEADERS)  # not cheap: waits for the slow one
    assert done.is_set() and r.status_code == 200
    thread.join(60)
