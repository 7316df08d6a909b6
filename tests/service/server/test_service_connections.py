"""Slow, idle, excess and vanishing clients against a real Uvicorn on 127.0.0.1.

The server runs in a thread of this process with the options ``kfio serve``
uses (:func:`kfio.service.connection_guard.uvicorn_options`) and short
deadlines.  Every loop is bounded by a count and every socket has a timeout,
so a server that never cuts a client off fails the test instead of hanging it.
"""

from __future__ import annotations

import asyncio
import json
import logging
import socket
import time
from collections.abc import Iterator

import httpx
import pytest

from kfio.service.connection_guard import RateLimitedLog, install_accept_error_log
from kfio.service.settings import Settings

from support.thread_server import ThreadServer

HEADER_TIMEOUT_S = 1.0
BODY_TIMEOUT_S = 1.0
MAX_CONNECTIONS = 12
#: A socket that the server should have closed within a deadline gets this long before the test fails.
HANG_GUARD_S = 20.0


@pytest.fixture(scope="module")
def server() -> Iterator[ThreadServer]:
    settings = Settings(
        workers=1,
        job_workers=1,
        header_timeout_s=HEADER_TIMEOUT_S,
        body_timeout_s=BODY_TIMEOUT_S,
        max_connections=MAX_CONNECTIONS,
    )
    with ThreadServer(settings) as live:
        yield live


def connect(server: ThreadServer) -> socket.socket:
    s = socket.create_connection(("127.0.0.1", server.port), timeout=HANG_GUARD_S)
    return s


def read_until_closed(s: socket.socket) -> bytes:
    """Everything the server sends until it closes (``socket.timeout`` if it never does)."""
    data = b""
    while True:
        part = s.recv(65536)
        if not part:
            return data
        data += part


def problem_of(answer: bytes) -> dict:
    head, _, body = answer.partition(b"\r\n\r\n")
    assert b"content-type: application/problem+json" in head.lower(), head
    return json.loads(body)


def trickle(s: socket.socket, data: bytes, pause_s: float = 0.1) -> int:
    """Send ``data`` one byte at a time; the number of bytes sent before the server closed the connection."""
    for i, byte in enumerate(data):
        try:
            s.send(bytes([byte]))
        except OSError:  # reset or broken pipe: the server closed it
            return i
        time.sleep(pause_s)
    return len(data)


def test_a_connection_that_sends_nothing_is_closed(server: ThreadServer) -> None:
    with connect(server) as s:
        answer = read_until_closed(s)
    assert answer.startswith(b"HTTP/1.1 408"), answer[:200]
    assert problem_of(answer)["type"] == "urn:kfio:problem:request-timeout"


def test_slow_headers_are_cut_off(server: ThreadServer) -> None:
    # 200 header bytes at 10 per second would take 20 s; the deadline is 1 s
    head = b"GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Pad: " + b"a" * 150 + b"\r\n\r\n"
    with connect(server) as s:
        sent = trickle(s, head)
        answer = read_until_closed(s)
    assert sent < len(head), "the server read every slow header byte"
    assert answer.startswith(b"HTTP/1.1 408") and b"headers" in answer, answer[:300]


def test_slow_body_is_cut_off_and_logged_as_a_disconnect(
    server: ThreadServer, caplog: pytest.LogCaptureFixture
) -> None:
    body = json.dumps({"system": {"A": [[2]], "C": [[1]]}, "pad": "x" * 150}).encode()
    head = b"POST /v1/analyze HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
    head += b"Content-Length: %d\r\n\r\n" % len(body)
    with caplog.at_level(logging.INFO), connect(server) as s:
        s.sendall(head)
        sent = trickle(s, body)
        answer = read_until_closed(s)
        for _ in range(200):  # bounded: the app sees the disconnect a moment after the close
            if any("disconnected" in r.getMessage() for r in caplog.records):
                break
            time.sleep(0.02)
    assert sent < len(body), "the server read every slow body byte"
    assert answer.startswith(b"HTTP/1.1 408") and b"body" in answer, answer[:300]
    assert [r for r in caplog.records if "disconnected" in r.getMessage() and r.levelno == logging.INFO]
    assert not [r for r in caplog.records if r.levelno >= logging.ERROR], [r.getMessage() for r in caplog.records]


def test_a_client_vanishing_mid_body_is_an_info_line_not_a_bug(
    server: ThreadServer, caplog: pytest.LogCaptureFixture
) -> None:
    head = b"POST /v1/analyze HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\nContent-Length: 1000\r\n\r\n"
    with caplog.at_level(logging.INFO):
        with connect(server) as s:
            s.sendall(head + b'{"system": ')
            time.sleep(0.2)  # the app is reading the body now
        for _ in range(200):
            if any("disconnected" in r.getMessage() for r in caplog.records):
                break
            time.sleep(0.02)
    messages = [(r.levelno, r.getMessage()) for r in caplog.records]
    assert any(level == logging.INFO and "disconnected" in m for level, m in messages), messages
    assert not any(level >= logging.ERROR or "bug" in m for level, m in messages), messages


def test_healthz_answers_while_slow_clients_are_held(server: ThreadServer) -> None:
    slow = [connect(server) for _ in range(MAX_CONNECTIONS // 2)]
    try:
        for s in slow:
            s.sendall(b"POST /v1/analyze HTTP/1.1\r\nHost: x\r\n")  # headers never finished
        assert httpx.get(f"{server.url}/healthz", timeout=HANG_GUARD_S).json() == {"status": "ok"}
        answers = [read_until_closed(s) for s in slow]
    finally:
        for s in slow:
            s.close()
    assert all(a.startswith(b"HTTP/1.1 408") for a in answers), answers
    assert httpx.get(f"{server.url}/healthz", timeout=HANG_GUARD_S).json() == {"status": "ok"}


def test_at_the_cap_a_new_client_displaces_the_oldest_idle_one(server: ThreadServer) -> None:
    # opened together, well within the header deadline: MAX_CONNECTIONS connections that send nothing
    idle = [connect(server) for _ in range(MAX_CONNECTIONS)]
    try:
        with connect(server) as s:  # one more, with a request: it gets its answer
            s.sendall(b"GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n")
            answer = read_until_closed(s)
        assert answer.startswith(b"HTTP/1.1 200") and answer.endswith(b'{"status":"ok"}'), answer[:300]
        # the connections owing their headers were closed with a 408, the oldest first, or at their deadline
        answers = [read_until_closed(c) for c in idle]
    finally:
        for c in idle:
            c.close()
    assert all(a.startswith(b"HTTP/1.1 408") for a in answers), answers


def test_at_the_cap_with_every_request_under_way_a_new_connection_gets_503(server: ThreadServer) -> None:
    # each held connection has sent its headers and owes its body: none can be displaced
    head = (
        b"POST /v1/analyze HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\nContent-Length: 50\r\n\r\n"
    )
    held = [connect(server) for _ in range(MAX_CONNECTIONS)]
    try:
        for c in held:
            c.sendall(head)
        # until the server has accepted every held connection and parsed its head, that connection still
        # owes its headers and a new one may displace it (a busy machine delays both): wait, bounded
        for _ in range(200):
            if server.guard.open >= MAX_CONNECTIONS and not server.guard.waiting:
                break
            time.sleep(0.005)
        refused = b""
        for _ in range(50):  # bounded: the server has read every head after a moment
            time.sleep(0.02)
            with connect(server) as s:
                refused = read_until_closed(s)
            if refused.startswith(b"HTTP/1.1 503"):
                break
        answers = [read_until_closed(c) for c in held]  # each is cut off at the body deadline
    finally:
        for c in held:
            c.close()
    assert refused.startswith(b"HTTP/1.1 503"), refused[:200]
    assert problem_of(refused)["type"] == "urn:kfio:problem:busy"
    assert all(a.startswith(b"HTTP/1.1 408") and b"body" in a for a in answers), answers


def test_malformed_http_is_a_problem(server: ThreadServer) -> None:
    with connect(server) as s:
        s.sendall(
            b"POST /v1/analyze HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: -1\r\n\r\n{}"
        )
        answer = read_until_closed(s)
    assert answer.startswith(b"HTTP/1.1 400"), answer[:200]
    assert problem_of(answer)["status"] == 400


def test_out_of_descriptors_is_one_log_line_not_a_flood(caplog: pytest.LogCaptureFixture) -> None:
    loop = asyncio.new_event_loop()
    try:
        install_accept_error_log(loop, RateLimitedLog(3600.0))
        with caplog.at_level(logging.DEBUG):
            for _ in range(1000):
                loop.call_exception_handler(
                    {
                        "message": "socket.accept() out of system resource",
                        "exception": OSError(24, "Too many open files"),
                    }
                )
    finally:
        loop.close()
    lines = [r for r in caplog.records if "accept" in r.getMessage()]
    assert len(lines) == 1 and "Too many open files" in lines[0].getMessage()
    assert lines[0].exc_info is None


def test_a_rebinding_host_name_is_refused_on_the_wire(server: ThreadServer) -> None:
    with connect(server) as s:
        s.sendall(b"GET /healthz HTTP/1.1\r\nHost: rebind.evil.example\r\nConnection: close\r\n\r\n")
        answer = read_until_closed(s)
    assert answer.startswith(b"HTTP/1.1 421"), answer[:200]
    assert problem_of(answer)["type"] == "urn:kfio:problem:misdirected-request"
