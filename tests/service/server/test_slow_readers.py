"""Slow readers are bounded (flow control, a send deadline, eviction at the cap).

Reproducer: 300 clients that request the ReDoc bundle and read 1 byte/s took
the server from 62 to 328-392 MiB: each connection buffered a whole copy of
the 1 MiB body, and nothing limited how long a response could take to drain.
The memory itself is measured by ``bench/bench_slow_readers.py``; here, with
a real Uvicorn in a thread, the mechanisms: what a stalled connection buffers,
that it is cut off at the send deadline, and that it makes room at the cap.
"""

from __future__ import annotations

import asyncio
import socket
import time
from collections.abc import Iterator
from typing import Any

import pytest

from kfio.service.api.web import offline_redoc
from kfio.service.app import create_app
from kfio.service.connection_guard import CHUNK_BYTES, ChunkedResponses
from kfio.service.settings import Settings

from support.thread_server import ThreadServer

PATH = "/docs-assets/redoc.standalone.js"
#: A socket the server should have cut off within a deadline gets this long before the test fails.
HANG_GUARD_S = 30.0


def test_a_large_body_is_handed_on_in_pieces_and_a_small_one_whole() -> None:
    body = bytes(range(256)) * 1000  # 256,000 bytes: 4 pieces
    sent: list[dict[str, Any]] = []

    async def app(scope: Any, receive: Any, send: Any) -> None:
        await send({"type": "http.response.start", "status": 200, "headers": []})
        await send({"type": "http.response.body", "body": body, "more_body": True})
        await send({"type": "http.response.body", "body": b"tail"})

    async def record(message: dict[str, Any]) -> None:
        sent.append(message)

    asyncio.run(ChunkedResponses(app)({"type": "http"}, None, record))
    bodies = [m for m in sent if m["type"] == "http.response.body"]
    assert [len(m["body"]) for m in bodies] == [CHUNK_BYTES] * 3 + [256_000 - 3 * CHUNK_BYTES, 4]
    assert b"".join(m["body"] for m in bodies) == body + b"tail"
    assert [m["more_body"] for m in bodies[:-1]] == [True] * 4 and bodies[-1].get("more_body", False) is False


#: Larger than what the kernel takes off the server's hands on loopback (a 4 MiB send buffer at most,
#: ``net.ipv4.tcp_wmem``), so that a client that reads nothing stalls the response in the server.
BIG_BYTES = 32 << 20
BIG = b"k" * BIG_BYTES


async def big_response(scope: Any, receive: Any, send: Any) -> None:
    """An ASGI app answering every request with :data:`BIG_BYTES` bytes, in one message (as ``Response`` does)."""
    if scope["type"] == "lifespan":
        while (await receive())["type"] != "lifespan.shutdown":
            pass
        return
    await send(
        {"type": "http.response.start", "status": 200, "headers": [(b"content-length", str(BIG_BYTES).encode())]}
    )
    await send({"type": "http.response.body", "body": BIG})


def _big_server(settings: Settings) -> ThreadServer:
    """Uvicorn with the options of ``kfio serve`` serving :func:`big_response` behind :class:`ChunkedResponses`."""
    return ThreadServer(settings, app=ChunkedResponses(big_response), lifespan="off")


def slow_reader(port: int) -> socket.socket:
    """A client that asks for a response and reads nothing (its receive window stays at 4 KiB)."""
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    s.settimeout(HANG_GUARD_S)
    s.connect(("127.0.0.1", port))
    s.sendall(f"GET {PATH} HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n".encode())
    return s


def wait(condition: Any, what: str) -> None:
    deadline = time.monotonic() + HANG_GUARD_S
    while not condition():
        assert time.monotonic() < deadline, what
        time.sleep(0.05)


def cut_off(s: socket.socket) -> bool:
    """Read what is left; True when the server ended the connection (reset or end of file)."""
    try:
        while s.recv(65536):
            pass
    except ConnectionResetError:
        return True
    except TimeoutError:
        return False
    return True


def test_a_reader_gets_the_whole_redoc_bundle_in_pieces() -> None:
    from fastapi.testclient import TestClient

    sent: list[int] = []
    app = create_app(Settings())

    async def spy(scope: Any, receive: Any, send: Any) -> None:  # below the app's middleware: what Uvicorn gets
        async def counted(message: Any) -> None:
            if message["type"] == "http.response.body":
                sent.append(len(message.get("body", b"")))
            await send(message)

        await app(scope, receive, counted)

    r = TestClient(spy).get(PATH)  # no lifespan: the bundle needs no worker
    assert r.status_code == 200 and r.content == offline_redoc()
    assert max(sent) == CHUNK_BYTES and sum(sent) == len(offline_redoc())
    assert int(r.headers["content-length"]) == len(offline_redoc()) > 8 * CHUNK_BYTES


@pytest.fixture(scope="module")
def server() -> Iterator[ThreadServer]:
    with _big_server(Settings(send_timeout_s=1.0, max_connections=6)) as live:
        yield live


def test_a_stalled_response_buffers_pieces_not_the_body_and_is_cut_off_at_the_send_deadline(
    server: ThreadServer,
) -> None:
    aborted = server.guard.aborted
    s = slow_reader(server.port)
    try:
        wait(lambda: server.guard.stalled, "the response never filled the transport's buffer")
        (protocol,) = list(server.guard.stalled)
        buffered = protocol.transport.get_write_buffer_size()
        assert 0 < buffered <= 2 * CHUNK_BYTES  # a piece or two of the 32 MiB body, not what is left of it
        wait(lambda: server.guard.aborted > aborted, "the stalled response was never cut off")
        assert cut_off(s)
    finally:
        s.close()
    wait(lambda: server.guard.open == 0 and not server.guard.stalled, "the aborted connection is still counted")


def test_at_the_cap_a_new_connection_takes_the_place_of_a_stalled_one() -> None:
    with _big_server(Settings(send_timeout_s=600, max_connections=3)) as live:
        readers = [slow_reader(live.port) for _ in range(3)]
        try:
            wait(lambda: len(live.guard.stalled) == 3, "three slow readers did not stall")
            first = next(iter(live.guard.stalled))
            with socket.create_connection(("127.0.0.1", live.port), timeout=10) as fourth:  # past the cap
                fourth.sendall(b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
                assert fourth.recv(64).startswith(b"HTTP/1.1 200")  # served, not refused with 503
            assert live.guard.aborted == 1 and first not in live.guard.stalled
            assert cut_off(readers[0])  # the longest stalled, opened first, made room
        finally:
            for s in readers:
                s.close()
