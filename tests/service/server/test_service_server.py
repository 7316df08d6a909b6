"""A real ``kfio serve`` (Uvicorn) subprocess, spoken to over loopback."""

from __future__ import annotations

import asyncio
import json
import os
import signal
import socket
import threading
import time
from collections.abc import Iterator

import httpx
import pytest

from kfio.service.api.schemas import REQUEST_EXAMPLES

from support.live_server import JSON_HEADERS, SLOW_PATH, LiveServer, slow_request
from support.live_server import OPENAPI_PATH as DEFAULT_PATH

SEED_2X2 = REQUEST_EXAMPLES["seed002-2x2"]["value"]


@pytest.fixture(scope="module")
def server() -> Iterator[LiveServer]:
    with LiveServer(workers=2, env={"KFIO_TIME_BUDGET_S": "10"}) as live:
        yield live


def raw_exchange(port: int, request: bytes, body_chunks: list[bytes], timeout: float = 10.0) -> bytes:
    """Send ``request`` and then ``body_chunks`` on a socket; return what the server answers."""
    with socket.create_connection(("127.0.0.1", port), timeout=timeout) as s:
        s.sendall(request)
        for chunk in body_chunks:
            s.sendall(chunk)
        data = b""
        while b"\r\n\r\n" not in data:
            part = s.recv(65536)
            if not part:
                break
            data += part
        return data


def test_health_docs_and_contract(server: LiveServer) -> None:
    assert httpx.get(f"{server.url}/healthz").json() == {"status": "ok"}
    assert httpx.get(f"{server.url}/readyz").json()["pool"]["size"] == 2
    assert "swagger" in httpx.get(f"{server.url}/docs").text.lower()
    # the checked-in contract is what the server publishes
    assert httpx.get(f"{server.url}/openapi.json").json() == json.loads(DEFAULT_PATH.read_text())


def test_analyze_over_loopback(server: LiveServer) -> None:
    r = httpx.post(f"{server.url}/v1/analyze", json=SEED_2X2, timeout=30)
    assert r.status_code == 200, r.text
    assert r.json()["verdict"] in {"stable", "unstable", "boundary"}
    again = httpx.post(
        f"{server.url}/v1/analyze", content=json.dumps(SEED_2X2, indent=1), headers=JSON_HEADERS, timeout=30
    )
    assert again.headers["x-cache"] == "hit" and again.content == r.content


def test_oversized_body_is_refused_on_its_content_length(server: LiveServer) -> None:
    # 100 MiB announced, nothing sent: the 413 comes without waiting for the body
    head = (
        b"POST /v1/analyze HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
        b"Content-Length: 104857600\r\n\r\n"
    )
    answer = raw_exchange(server.port, head, [], timeout=60)  # no body is ever sent: an answer proves it
    assert answer.startswith(b"HTTP/1.1 413"), answer[:200]
    assert b"application/problem+json" in answer


def test_oversized_chunked_body_is_refused_while_streaming(server: LiveServer) -> None:
    # no Content-Length: the server counts while reading and stops past 1 MiB
    head = (
        b"POST /v1/analyze HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
        b"Transfer-Encoding: chunked\r\n\r\n"
    )
    piece = b"x" * 65536
    chunks = [b"%x\r\n%s\r\n" % (len(piece), piece)] * 16 + [b"1\r\nx\r\n"]  # 1 MiB + 1 byte, never terminated
    answer = raw_exchange(server.port, head, chunks)
    assert answer.startswith(b"HTTP/1.1 413"), answer[:200]


def test_timeout_is_504_and_the_server_keeps_serving(server: LiveServer) -> None:
    r = httpx.post(
        f"{server.url}{SLOW_PATH}", content=slow_request(time_budget_s=1, seed=21), headers=JSON_HEADERS, timeout=30
    )
    assert r.status_code == 504 and r.headers["content-type"] == "application/problem+json"
    assert (
        httpx.post(f"{server.url}/v1/analyze", json=REQUEST_EXAMPLES["seed004-3x3"]["value"], timeout=30).status_code
        == 200
    )
    # the 504 came from the budget (checked between simulation steps) or from killing the worker
    # (the kill path itself: tests/test_service_pool.py); either way the pool is whole again
    for _ in range(1200):  # bounded by count: a replacement may take seconds on a loaded machine
        pool = httpx.get(f"{server.url}/readyz").json()["pool"]
        if pool["alive"] == pool["size"] and pool["busy"] == 0:
            break
        time.sleep(0.05)
    assert pool["alive"] == pool["size"] and pool["busy"] == 0, pool


@pytest.mark.slow
def test_healthz_answers_while_every_worker_is_busy(server: LiveServer) -> None:
    async def scenario() -> list[int]:
        async with httpx.AsyncClient(base_url=server.url, timeout=30) as client:

            def post(budget_s: float, seed: int) -> asyncio.Task[httpx.Response]:
                body = slow_request(time_budget_s=budget_s, seed=seed)
                return asyncio.create_task(client.post(SLOW_PATH, content=body, headers=JSON_HEADERS))

            running = [post(10, s) for s in (31, 32)]  # two for two workers
            for _ in range(1200):  # bounded by count: a hang guard
                if (await client.get("/readyz")).json()["pool"]["busy"] == 2:
                    break
                await asyncio.sleep(0.02)
            assert (await client.get("/readyz")).json()["pool"]["busy"] == 2, "the pool never filled"
            # The third is sent only once both workers are provably busy, with a budget that ends long before
            # theirs: it can only wait in the queue and be refused.  (Sent together with the other two and
            # the same budget, it raced them: a worker that stopped at its own budget check a moment before
            # the queued request's deadline took the queued request, which then ran out of budget: 504.)
            queued = post(1, 33)
            for _ in range(30):
                assert (await client.get("/healthz")).status_code == 200
                await asyncio.sleep(0.01)
            # every health answer came while both workers were provably busy
            assert (await client.get("/readyz")).json()["pool"]["busy"] == 2
            return [r.status_code for r in await asyncio.gather(*running, queued)]

    statuses = asyncio.run(scenario())
    # the two that ran out of budget in a worker: 504; the one that never got a worker: 503
    assert statuses == [504, 504, 503]


def descendants(pid: int) -> set[int]:
    """Every live process below ``pid`` (from /proc)."""
    children: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                stat = open(f"/proc/{entry}/stat").read()
            except OSError:
                continue
            ppid = int(stat.rsplit(")", 1)[1].split()[1])
            children.setdefault(ppid, []).append(int(entry))
    out, todo = set(), [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            out.add(child)
            todo.append(child)
    return out


def alive(pid: int) -> bool:
    try:
        state = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.slow  # starts its own server
@pytest.mark.skipif(not os.path.isdir("/proc"), reason="needs /proc")
def test_workers_die_with_a_killed_server_even_mid_computation() -> None:
    with LiveServer(workers=2) as live:
        for seed in (41, 42):  # both workers busy with long batched Riccati steps (numpy C calls)
            body = slow_request(time_budget_s=600, seed=seed)
            threading.Thread(target=lambda b=body: _post_quietly(live.url, b), daemon=True).start()
        for _ in range(1200):  # bounded by count: a hang guard
            if httpx.get(f"{live.url}/readyz").json()["pool"]["busy"] == 2:
                break
            time.sleep(0.05)
        assert httpx.get(f"{live.url}/readyz").json()["pool"]["busy"] == 2
        below = descendants(live.proc.pid)  # forkserver, workers, resource tracker
        assert len(below) >= 3
        os.kill(live.proc.pid, signal.SIGKILL)
        live.proc.wait(timeout=10)
        for _ in range(600):  # bounded by count: a hang guard
            if not any(alive(p) for p in below):
                break
            time.sleep(0.1)
        assert not [p for p in below if alive(p)], "processes outlived the killed server"


def _post_quietly(url: str, body: bytes) -> None:
    try:
        httpx.post(f"{url}{SLOW_PATH}", content=body, headers=JSON_HEADERS, timeout=30)
    except httpx.HTTPError:
        pass  # the server is killed under it
