"""A real Uvicorn with the options of ``kfio serve``, in a thread of the test process, on a free port of 127.0.0.1."""

from __future__ import annotations

import threading
import time
from typing import Any

import uvicorn

from kfio.service.app import create_app
from kfio.service.connection_guard import uvicorn_options
from kfio.service.settings import Settings


class ThreadServer:
    """``with ThreadServer(settings) as live: ... live.url``: kfio's app (or ``app``) behind kfio's connection guard.

    The start is bounded (about 20 s); leaving the block asks the server to exit and joins its thread.
    """

    def __init__(self, settings: Settings, app: Any = None, log_level: str = "info", lifespan: str = "on") -> None:
        options = uvicorn_options(settings)
        self.guard = options["http"].guard
        config = uvicorn.Config(
            create_app(settings) if app is None else app,
            host="127.0.0.1",
            port=0,
            loop="asyncio",
            log_level=log_level,
            lifespan=lifespan,
            **options,
        )
        self.server = uvicorn.Server(config)
        self.thread = threading.Thread(target=self.server.run, daemon=True)

    def __enter__(self) -> ThreadServer:
        self.thread.start()
        for _ in range(2000):  # bounded: about 20 s
            if self.server.started:
                break
            time.sleep(0.01)
        assert self.server.started, "the server did not start"
        self.port = self.server.servers[0].sockets[0].getsockname()[1]
        self.url = f"http://127.0.0.1:{self.port}"
        return self

    def __exit__(self, *exc: object) -> None:
        self.server.should_exit = True
        self.thread.join(timeout=30)
