"""SIGTERM while requests run: every client gets a problem document.

A real ``kfio serve`` with one worker: one request computes, one waits for
the worker.  On SIGTERM the waiting one is refused at once, the running one
when the grace period ends; both are 503 ``shutting-down`` problem+json with
``Retry-After``, never Uvicorn's ``500 text/plain``.
"""

from __future__ import annotations

import asyncio
import signal
import socket

import httpx
import pytest

from kfio.service import exitcodes

from support.live_server import JSON_HEADERS, SLOW_PATH, LiveServer, slow_request


async def _wait_for(client: httpx.AsyncClient, busy: int, waiting: int) -> None:
    for _ in range(600):  # bounded by count; each poll is one round trip
        pool = (await client.get("/readyz")).json()["pool"]
        if pool["busy"] >= busy and pool["waiting"] >= waiting:
            return
        await asyncio.sleep(0.05)
    raise AssertionError(f"the pool never reached busy={busy}, waiting={waiting}")


@pytest.mark.slow  # starts its own server: tens of seconds on a loaded machine
def test_sigterm_answers_running_and_queued_requests_with_503_problems() -> None:
    with LiveServer(workers=1, env={"KFIO_SHUTDOWN_GRACE_S": "1", "KFIO_TIME_BUDGET_S": "600"}) as live:
        assert live.proc is not None

        async def scenario() -> list[httpx.Response]:
            async with httpx.AsyncClient(base_url=live.url, timeout=60) as client:
                running = asyncio.create_task(
                    client.post(SLOW_PATH, content=slow_request(600, seed=51), headers=JSON_HEADERS)
                )
                await _wait_for(client, busy=1, waiting=0)
                queued = asyncio.create_task(
                    client.post(SLOW_PATH, content=slow_request(600, seed=52), headers=JSON_HEADERS)
                )
                await _wait_for(client, busy=1, waiting=1)
                live.proc.send_signal(signal.SIGTERM)
                return list(await asyncio.gather(running, queued))

        answers = asyncio.run(scenario())
        live.proc.wait(timeout=60)
    for r in answers:
        assert r.status_code == 503, r.text
        assert r.headers["content-type"] == "application/problem+json"
        assert int(r.headers["retry-after"]) > 0
        assert r.json()["type"] == "urn:kfio:problem:shutting-down"
    running, queued = (r.json()["detail"] for r in answers)
    assert "grace period" in running and "before it ran" in queued


def test_serve_on_a_busy_port_exits_cannot_serve(capsys: object) -> None:
    from kfio.service.cli import main

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        assert main(["serve", "--host", "127.0.0.1", "--port", str(port)]) == exitcodes.CANNOT_SERVE == 6
    assert exitcodes.CANNOT_SERVE not in exitcodes.BY_VERDICT.values()
