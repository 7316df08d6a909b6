"""Slow, idle and excess connections are cut off before they can hold the server.

Uvicorn waits forever for a request's headers and body: a client that opens a
connection and sends nothing, or sends one byte a second, holds a file
descriptor until it goes away, and a few hundred such clients exhaust the
process's descriptors (then ``/healthz`` stops answering too).
:func:`guarded_protocol` wraps Uvicorn's HTTP protocol class with three rules:

* **Header deadline** (``KFIO_HEADER_TIMEOUT_S``): a request's headers must be
  complete this long after the connection opens, or after the first byte of a
  later request on a kept-alive connection.  A connection that sends nothing
  is closed then too.
* **Body deadline** (``KFIO_BODY_TIMEOUT_S``): the body must be complete this
  long after the headers.
* **Send deadline** (``KFIO_SEND_TIMEOUT_S``): a response whose client reads
  so little that the transport's write buffer stays above its high-water mark
  (asyncio's ``pause_writing``, 64 KiB) for this long is cut off: the
  connection is aborted and its buffer dropped.
* **Connection cap** (``KFIO_MAX_CONNECTIONS``, lowered to fit the process's
  descriptor limit): every open connection counts, a response in flight
  too.  A new connection past it takes the place of the oldest connection
  that has not sent its request's headers yet (that one gets ``408``), else of
  the oldest one whose response is stalled (its client is not reading: it is
  aborted); when there is neither, the new one is answered ``503 busy`` at
  once and closed, without reading its request.  So clients that hold
  connections without sending requests, or without reading answers, cannot
  lock out the ones that do.

Flow control: :class:`ChunkedResponses` (ASGI middleware) hands Uvicorn any
response body larger than :data:`CHUNK_BYTES` in pieces of that size, and
Uvicorn waits for the transport to drain below its high-water mark before each
piece; so a connection buffers at most about two pieces, however large the
response (the 1 MiB ReDoc bundle) and however slow its reader, instead of a
whole copy of the body per connection.

A deadline that passes before the response has started is answered ``408``
(problem+json, ``Connection: close``); the connection is closed either way.
Idle kept-alive connections are closed by Uvicorn after ``KFIO_KEEP_ALIVE_S``.
Malformed HTTP (a negative ``Content-Length``, ...) is answered ``400``
problem+json instead of Uvicorn's ``text/plain``.

When the process runs out of descriptors anyway, asyncio stops accepting for a
second and retries; :func:`install_accept_error_log` turns its traceback per
retry into one log line per :data:`LOG_INTERVAL_S`.

Why Uvicorn is pinned: the rules above live in a subclass of Uvicorn's HTTP
protocol classes and read their private state (``cycle``, ``more_body``,
``send_400_response``), which any Uvicorn release may change.  So the guard
claims only the releases its tests passed on, :data:`PROVEN_UVICORN`, and
``pyproject.toml`` pins exactly that range; a test fails when the pin and this
range differ or when the installed Uvicorn lies outside it.  Widen both after
the connection tests pass on the new release.
"""

from __future__ import annotations

import asyncio
import json
import logging
import resource
import time
from typing import Any, Callable, cast

from .problems import MEDIA_TYPE, Problem

log = logging.getLogger("kfio.service")

#: Uvicorn releases the guard was proven on: from the first, inclusive, to the second, exclusive
#: (the ``uvicorn>=A,<B`` pin of pyproject.toml).
PROVEN_UVICORN = ("0.29", "0.56")

#: Descriptors kept free for the worker pools' pipes, the log and the app's own files.
RESERVED_FDS = 64

#: At most one log line per this many seconds for each kind of refusal.
LOG_INTERVAL_S = 10.0

#: Largest piece of a response body handed to the server at once (see :class:`ChunkedResponses`).
CHUNK_BYTES = 64 * 1024

_REASONS = {400: b"Bad Request", 408: b"Request Timeout", 503: b"Service Unavailable"}


class RateLimitedLog:
    """Log the first event of a kind, then at most one line per ``interval`` seconds with a count.

    Examples
    --------
    >>> clock = iter([0.0, 1.0, 2.0, 20.0]).__next__
    >>> lines = []
    >>> rl = RateLimitedLog(10.0, emit=lines.append, clock=clock)
    >>> for _ in range(4):
    ...     rl.note("refused")
    >>> lines
    ['refused', 'refused (3 times in the last 10 s)']
    """

    def __init__(
        self,
        interval: float = LOG_INTERVAL_S,
        emit: Callable[[str], None] | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.interval = interval
        self.emit = emit if emit is not None else log.warning
        self.clock = clock
        self._last: dict[str, float] = {}
        self._count: dict[str, int] = {}

    def note(self, message: str) -> None:
        """Count one event; log it if the last line of this message is older than the interval."""
        now = self.clock()
        self._count[message] = self._count.get(message, 0) + 1
        last = self._last.get(message)
        if last is not None and now - last < self.interval:
            return
        count = self._count.pop(message)
        self._last[message] = now
        self.emit(message if last is None else f"{message} ({count} times in the last {self.interval:g} s)")


def raw_problem(status: int, kind: str, title: str, detail: str) -> bytes:
    """A complete ``HTTP/1.1`` problem+json response with ``Connection: close``, as bytes.

    For answers written straight to a transport, outside any ASGI cycle.
    """
    body = json.dumps(Problem(status, kind, title, detail).to_dict()).encode()
    head = (
        f"HTTP/1.1 {status} ".encode()
        + _REASONS.get(status, b"Error")
        + f"\r\ncontent-type: {MEDIA_TYPE}\r\ncontent-length: {len(body)}\r\nconnection: close\r\n\r\n".encode()
    )
    return head + body


def connection_cap(wanted: int, reserved: int = RESERVED_FDS) -> int:
    """``wanted``, lowered so that the connections fit in the descriptor limit (``RLIMIT_NOFILE``) with ``reserved`` spare."""
    soft, _ = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft == resource.RLIM_INFINITY:
        return wanted
    return max(1, min(wanted, soft - reserved))


class Guard:
    """The rules shared by every connection of one server (see the module docstring)."""

    def __init__(
        self, header_timeout_s: float, body_timeout_s: float, max_connections: int, send_timeout_s: float = 30.0
    ) -> None:
        self.header_timeout_s = header_timeout_s
        self.body_timeout_s = body_timeout_s
        self.send_timeout_s = send_timeout_s
        self.max_connections = max_connections
        self.open = 0
        self.log = RateLimitedLog()
        #: Connections still waiting for a request's headers, oldest first (a dict as an ordered set).
        self.waiting: dict[Any, None] = {}
        #: Connections whose response cannot be written (the client is not reading), longest stalled first.
        self.stalled: dict[Any, None] = {}
        #: Connections aborted because their client read nothing for ``send_timeout_s`` or at the cap.
        self.aborted = 0


def guarded_protocol(base: type[asyncio.Protocol], guard: Guard) -> type[asyncio.Protocol]:
    """A subclass of Uvicorn's HTTP protocol class ``base`` that enforces ``guard``.

    It relies on what Uvicorn's two HTTP protocols (h11 and httptools) share:
    ``self.cycle`` is the current request, created when its headers are
    complete, and ``cycle.more_body`` turns false when its body is; and on
    asyncio's public protocol methods ``pause_writing``/``resume_writing``,
    which both forward to their flow control.
    """

    class GuardedProtocol(base):  # type: ignore[valid-type, misc]
        _refused = False
        _counted = False
        _deadline: asyncio.TimerHandle | None = None
        _waiting_for: str | None = None
        _send_deadline: asyncio.TimerHandle | None = None

        def connection_made(self, transport: asyncio.BaseTransport) -> None:
            while guard.open >= guard.max_connections and guard.waiting:
                next(iter(guard.waiting))._evict()  # the oldest connection still owing its headers makes room
            while guard.open >= guard.max_connections and guard.stalled:
                next(iter(guard.stalled))._abort("its client had read nothing when the connection cap was reached")
            if guard.open >= guard.max_connections:
                self._refused = True
                self.transport = transport
                guard.log.note(
                    f"connection refused: {guard.max_connections} connections are open (KFIO_MAX_CONNECTIONS)"
                )
                transport.write(  # type: ignore[attr-defined]
                    raw_problem(
                        503,
                        "busy",
                        "Service busy",
                        f"the server holds its maximum of {guard.max_connections} connections; retry shortly",
                    )
                )
                transport.close()
                return
            guard.open += 1
            self._counted = True
            super().connection_made(transport)
            self._arm("headers", guard.header_timeout_s)

        def connection_lost(self, exc: Exception | None) -> None:
            self._disarm()
            self._unstall()
            if self._refused:
                return
            if self._counted:
                guard.open -= 1
                self._counted = False
            super().connection_lost(exc)

        def data_received(self, data: bytes) -> None:
            if self._refused:
                return
            before = self.cycle
            super().data_received(data)
            self._follow(before)

        def pause_writing(self) -> None:
            super().pause_writing()
            if self._send_deadline is None:
                self._send_deadline = self.loop.call_later(
                    guard.send_timeout_s, self._abort, f"its client read nothing for {guard.send_timeout_s:g} s"
                )
                guard.stalled[self] = None

        def resume_writing(self) -> None:
            self._unstall()
            super().resume_writing()

        def _unstall(self) -> None:
            if self._send_deadline is not None:
                self._send_deadline.cancel()
                self._send_deadline = None
            guard.stalled.pop(self, None)

        def _abort(self, why: str) -> None:
            """Drop this connection and what its transport still buffers (its response cannot be delivered)."""
            self._unstall()
            if self._counted:  # counted out now: a new connection may take its place at once
                guard.open -= 1
                self._counted = False
            transport = cast("asyncio.Transport | None", self.transport)
            if transport is None or (transport.is_closing() and not transport.get_write_buffer_size()):
                return
            guard.aborted += 1
            guard.log.note(f"connection aborted with a response in flight: {why}")
            transport.abort()  # close() would wait for the buffer to drain, which it does not

        def _follow(self, before: Any) -> None:
            """Arm or disarm the deadline after the parser has read new bytes."""
            if self.transport is None or self.transport.is_closing():
                self._disarm()
                return
            cycle = self.cycle
            if cycle is not None and cycle is not before:  # a request's headers are complete
                if cycle.more_body:
                    self._arm("body", guard.body_timeout_s)
                else:
                    self._disarm()  # the whole request is here: the app's turn
            elif cycle is not None and cycle.more_body:
                pass  # more of the body: its deadline runs on
            elif self._waiting_for == "body":
                self._disarm()  # the body is complete
            elif self._waiting_for is None and (cycle is None or cycle.response_complete):
                self._arm("headers", guard.header_timeout_s)  # the first bytes of the next request

        def _arm(self, what: str, seconds: float) -> None:
            self._disarm()
            self._waiting_for = what
            self._deadline = self.loop.call_later(seconds, self._expired, what, seconds)
            if what == "headers":
                guard.waiting[self] = None

        def _disarm(self) -> None:
            if self._deadline is not None:
                self._deadline.cancel()
            self._deadline = None
            self._waiting_for = None
            guard.waiting.pop(self, None)

        def _evict(self) -> None:
            """Close this connection, which owes its request's headers, to make room for a new one."""
            self._disarm()
            if self._counted:  # counted out now: the new connection takes its place at once
                guard.open -= 1
                self._counted = False
            if self.transport.is_closing():
                return
            guard.log.note("connection closed: it had sent no complete request when the connection cap was reached")
            detail = (
                "the request's headers had not arrived when the server, at its connection cap, needed the connection"
            )
            cast("asyncio.Transport", self.transport).write(
                raw_problem(408, "request-timeout", "Request timeout", detail)
            )
            self.transport.close()

        def _expired(self, what: str, seconds: float) -> None:
            self._deadline = None
            self._waiting_for = None
            guard.waiting.pop(self, None)
            if self.transport is None or self.transport.is_closing():
                return
            guard.log.note(f"connection closed: request {what} not received within {seconds:g} s")
            cycle = self.cycle
            if what == "headers" or not cycle.response_started:  # nothing was answered yet: say why
                detail = f"the request's {what} did not arrive within {seconds:g} s"
                cast("asyncio.Transport", self.transport).write(
                    raw_problem(408, "request-timeout", "Request timeout", detail)
                )
            self.transport.close()

        def send_400_response(self, msg: str) -> None:
            guard.log.note("malformed HTTP request refused (400)")
            cast("asyncio.Transport", self.transport).write(
                raw_problem(400, "malformed-http", "Malformed HTTP request", msg)
            )
            self.transport.close()

    GuardedProtocol.__name__ = GuardedProtocol.__qualname__ = f"Guarded{base.__name__}"
    GuardedProtocol.guard = guard  # the state it enforces, for inspection (tests wait on it)
    return GuardedProtocol


def install_accept_error_log(loop: asyncio.AbstractEventLoop, limiter: RateLimitedLog | None = None) -> None:
    """Turn asyncio's traceback per failed ``accept()`` (out of descriptors) into one rate-limited line.

    asyncio already stops accepting for a second when ``accept()`` fails with
    ``EMFILE``/``ENFILE``; the waiting clients stay in the listen backlog.
    Every other error goes to the handler that was there before.
    """
    limiter = limiter or RateLimitedLog()
    previous = loop.get_exception_handler()

    def handler(loop: asyncio.AbstractEventLoop, context: dict[str, Any]) -> None:
        if context.get("message") == "socket.accept() out of system resource":
            exc = context.get("exception")
            limiter.note(f"cannot accept connections: {getattr(exc, 'strerror', None) or exc}; retrying every second")
            return
        if previous is not None:
            previous(loop, context)
        else:
            loop.default_exception_handler(context)

    loop.set_exception_handler(handler)


def uvicorn_options(settings: Any) -> dict[str, Any]:
    """The ``uvicorn.Config`` options that apply the guard of ``settings`` (:class:`kfio.service.settings.Settings`).

    The cap answers 503 problem+json at accept time, so Uvicorn's own
    ``limit_concurrency`` (a ``text/plain`` 503 after reading the request, and
    a warning per refusal) is not used.
    """
    from uvicorn.protocols.http.auto import AutoHTTPProtocol

    cap = connection_cap(settings.max_connections)
    if cap < settings.max_connections:
        log.warning("at most %d connections: the process's descriptor limit allows no more", cap)
    guard = Guard(settings.header_timeout_s, settings.body_timeout_s, cap, settings.send_timeout_s)
    return {"http": guarded_protocol(AutoHTTPProtocol, guard), "timeout_keep_alive": settings.keep_alive_s}


class ChunkedResponses:
    """ASGI middleware: a response body larger than :data:`CHUNK_BYTES` is sent in pieces of that size.

    Uvicorn waits, before each ``send``, until the transport has drained below
    its high-water mark; with the body in pieces a slow reader holds at most
    a piece or two in the server, not a copy of the whole body.
    """

    def __init__(self, app: Any, chunk_bytes: int = CHUNK_BYTES) -> None:
        self.app = app
        self.chunk_bytes = chunk_bytes

    async def __call__(self, scope: Any, receive: Any, send: Any) -> None:
        if scope.get("type") != "http":
            await self.app(scope, receive, send)
            return

        async def chunked_send(message: Any) -> None:
            body = message.get("body", b"") if message.get("type") == "http.response.body" else b""
            if len(body) <= self.chunk_bytes:
                await send(message)
                return
            more = message.get("more_body", False)
            for start in range(0, len(body), self.chunk_bytes):
                piece = bytes(body[start : start + self.chunk_bytes])
                last = start + self.chunk_bytes >= len(body)
                await send({"type": "http.response.body", "body": piece, "more_body": more or not last})

        await self.app(scope, receive, chunked_send)
