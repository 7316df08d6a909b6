"""Dependencies shared by the routes, as ``Annotated`` aliases."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request

from ..dispatch import Dispatcher, read_body, require_json
from ..problems import Problem, ProblemError


async def get_dispatcher(request: Request) -> Dispatcher:
    """The app's dispatcher (created by the lifespan; 503 before it runs).

    ``async`` although it awaits nothing: FastAPI runs a plain ``def`` dependency in a thread,
    a hop that cost more than the rest of a cached answer (bench/bench_service.py).
    """
    dispatcher: Dispatcher | None = getattr(request.app.state, "dispatcher", None)
    if dispatcher is None:
        raise ProblemError(Problem(503, "not-ready", "Service not ready", "the service is starting", retry_after=1))
    return dispatcher


DispatcherDep = Annotated[Dispatcher, Depends(get_dispatcher)]


async def get_body(request: Request, dispatcher: DispatcherDep) -> bytes:
    """The raw request body: JSON (415 otherwise), at most ``settings.max_body_bytes`` (413 beyond)."""
    require_json(request.headers.get("content-type"))
    return await read_body(request, dispatcher.settings.max_body_bytes)


BodyDep = Annotated[bytes, Depends(get_body)]
