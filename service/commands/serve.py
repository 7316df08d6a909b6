"""``kfio serve [--host H] [--port P] [--workers N]``: the HTTP service (Uvicorn).

On SIGTERM (or Ctrl-C) the server stops accepting connections and drains its
worker pool: requests waiting for a worker are refused at once, running ones
get ``shutdown_grace_s`` (``KFIO_SHUTDOWN_GRACE_S``) to finish, and whatever is
still running then is answered 503 ``shutting-down`` with ``Retry-After``
(problem+json, never Uvicorn's bare ``500 text/plain``).  If the server cannot
start (the port is taken, ``KFIO_DASK_SCHEDULER`` names a scheduler that
cannot be reached, ...), the exit code is 6, ``CANNOT_SERVE``.

Bound to an address beyond this machine with no access token configured, the
server generates one and prints it first (:func:`kfio.service.auth.startup_tokens`);
``KFIO_AUTH=none`` serves without.
"""

from __future__ import annotations

import argparse
import asyncio
import socket
import sys
from typing import Any

from .. import exitcodes

#: Seconds Uvicorn waits for connections past the drain's grace period before it cancels them.
UVICORN_MARGIN_S = 5.0


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "serve",
        help="run the HTTP service",
        description="Serve the kfio HTTP API (docs at /docs). Every option also reads KFIO_<NAME> from the "
        "environment (KFIO_TIME_BUDGET_S, KFIO_MAX_QUEUE, KFIO_MEMORY_MB, ...); command-line options win. "
        "Bound beyond loopback (--host 0.0.0.0) with no KFIO_API_TOKEN or KFIO_API_TOKEN_FILE, it generates an "
        "access token and prints it (KFIO_AUTH=none serves without). "
        "Exit 2 when a setting is out of range (the message names it), 6 when the server cannot start (the port is in use, a worker pool cannot start).",
    )
    p.add_argument("--host", help="interface to listen on (default 127.0.0.1)")
    p.add_argument("--port", type=int, help="TCP port (default 8000)")
    p.add_argument("--workers", type=int, help="analysis worker processes (default: CPU count, at most 4)")
    p.add_argument("--log-level", default="info", choices=["critical", "error", "warning", "info", "debug"])
    p.set_defaults(func=_run)


def port_in_use(host: str, port: int) -> str | None:
    """Why ``host:port`` cannot be bound now (``None`` if it can)."""
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except OSError as exc:
        return f"cannot resolve {host}: {exc.strerror or exc}"
    family, kind, proto, _, address = infos[0]
    with socket.socket(family, kind, proto) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as Uvicorn does
        try:
            s.bind(address)
        except OSError as exc:
            return f"cannot listen on {host}:{port}: {exc.strerror or exc}"
    return None


def setting_error(exc: Any, flags: dict[str, Any]) -> str:
    """One line naming the setting (its flag, or its ``KFIO_`` variable) and the rule it broke.

    ``exc`` is the ``pydantic.ValidationError`` of :class:`kfio.service.settings.Settings`.
    """
    err = exc.errors()[0]
    name = str(err["loc"][0]) if err.get("loc") else "settings"
    where = f"--{name.replace('_', '-')}" if name in flags else f"KFIO_{name.upper()}"
    return f"invalid setting {where}: {err['msg']}"


def _run(args: argparse.Namespace) -> int:
    import uvicorn
    from pydantic import ValidationError

    from ..app import create_app
    from ..auth import SettingError, startup_tokens
    from ..connection_guard import install_accept_error_log, uvicorn_options
    from ..settings import Settings

    overrides = {k: getattr(args, k) for k in ("host", "port", "workers") if getattr(args, k) is not None}
    try:
        settings = Settings(**overrides)
    except ValidationError as exc:
        print(f"kfio: {setting_error(exc, overrides)}", file=sys.stderr)
        return exitcodes.INVALID_INPUT
    from ..jobdb import data_dir_problem, default_data_dir

    # the served app keeps its jobs on disk (an app built in a test, without data_dir, in memory)
    data_dir = settings.data_dir or str(default_data_dir())
    settings = settings.model_copy(update={"data_dir": data_dir})
    reason = data_dir_problem(data_dir)
    if reason is not None:  # another server holds it, or it cannot be written: say so, naming the setting
        print(f"kfio: {reason}", file=sys.stderr)
        return exitcodes.CANNOT_SERVE
    if settings.port != 0:
        reason = port_in_use(settings.host, settings.port)
        if reason is not None:  # checked before the worker pool starts, for a clear message
            print(f"kfio: {reason}", file=sys.stderr)
            return exitcodes.CANNOT_SERVE
    if settings.dask_scheduler:
        from ..sweep_jobs import dask_scheduler_problem

        reason = dask_scheduler_problem(settings.dask_scheduler)
        if reason is not None:  # every sweep would fail: say so now, naming the setting
            print(f"kfio: setting KFIO_DASK_SCHEDULER: {reason}", file=sys.stderr)
            return exitcodes.CANNOT_SERVE
    try:
        settings, announcement = startup_tokens(settings)
    except SettingError as exc:
        print(f"kfio: invalid setting {exc.setting}: {exc.rule}", file=sys.stderr)
        return exitcodes.INVALID_INPUT
    if announcement is not None:  # as Jupyter does: the operator reads the token from the server's output
        print(announcement, file=sys.stderr, flush=True)
    app = create_app(settings)

    class DrainingServer(uvicorn.Server):
        """Uvicorn's server, draining the worker pool while it waits for connections to finish."""

        start_error: BaseException | None = None

        async def startup(self, sockets: Any = None) -> None:
            install_accept_error_log(asyncio.get_running_loop())  # out of descriptors: one line, not a flood
            await super().startup(sockets)
            starting = getattr(app.state, "starting", None)
            if starting:
                self._watch = asyncio.create_task(self._stop_if_pools_fail(starting))

        async def _stop_if_pools_fail(self, starting: list[asyncio.Task[None]]) -> None:
            """A pool that cannot start stops the server (exit 6): never serve 503 forever."""
            for outcome in await asyncio.gather(*starting, return_exceptions=True):
                if isinstance(outcome, Exception) and not self.should_exit:
                    self.start_error = outcome
                    self.should_exit = True

        async def shutdown(self, sockets: Any = None) -> None:
            dispatcher = getattr(app.state, "dispatcher", None)
            drain = None
            if dispatcher is not None:
                drain = asyncio.create_task(dispatcher.pool.drain(settings.shutdown_grace_s))
            await super().shutdown(sockets)
            if drain is not None:
                await asyncio.gather(drain, return_exceptions=True)

    # One server process: the analysis runs in the pool's worker processes, and
    # one process keeps one cache.
    config = uvicorn.Config(
        app,
        host=settings.host,
        port=settings.port,
        log_level=args.log_level,
        # The standard loop, even where uvloop is installed: uvloop's add_reader makes the worker
        # pipes non-blocking, and a large answer (a plot) would then be read as a crashed worker.
        loop="asyncio",
        **uvicorn_options(settings),  # slow, idle and excess connections are cut off
        timeout_graceful_shutdown=int(settings.shutdown_grace_s + UVICORN_MARGIN_S),
    )
    server = DrainingServer(config)
    try:
        server.run()
    except SystemExit as exc:  # Uvicorn exits 3 when it cannot bind or the app does not start
        if exc.code in (0, None):
            return exitcodes.STABLE
        print("kfio: the server could not start (see the log above)", file=sys.stderr)
        return exitcodes.CANNOT_SERVE
    if server.start_error is not None:
        print(f"kfio: the worker pool could not start ({server.start_error}); stopped", file=sys.stderr)
        return exitcodes.CANNOT_SERVE
    return exitcodes.STABLE
