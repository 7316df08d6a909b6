"""The FastAPI application: ``create_app(settings)`` builds it, nothing at import.

Run it with ``kfio serve`` (see :mod:`kfio.service.commands.serve`) or, for
development, ``uvicorn --factory kfio.service.app:create_app``.
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

from fastapi import FastAPI
from fastapi.exceptions import RequestValidationError
from fastapi.openapi.utils import get_openapi
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.requests import ClientDisconnect

from kfio._version import __version__
from kfio.errors import AnalyzerError

from .api import api_router, web
from .api.schemas import COMPONENTS
from .auth import BearerAuth, configured_tokens, declare_security
from .connection_guard import ChunkedResponses
from .dispatch import Dispatcher
from .host_check import HostCheck, parse_hosts
from .jobstore import JobStore
from .problems import ProblemError, disconnect_handler, problem_handler
from .settings import Settings, get_settings

#: OpenAPI ``info.version``: the package's version (the HTTP contract ships with the package).
API_VERSION = __version__

DESCRIPTION = """\
Stability analysis of Kalman filters whose measurements travel over lossy packet channels.

* Every `POST` takes the request JSON of the `kfio` CLI (the same file) and returns its `--json` report,
  or a PNG for `/v1/plots/...`.  Numbers are exact: `1.1` means 11/10; strings such as `"11/10"` work too.
* Errors are `application/problem+json` (RFC 9457).  Invalid input is 422 with `field`
  (a JSON pointer into the request) and `rule`.  Bodies over 1 MiB are refused with 413, bodies
  not sent as `Content-Type: application/json` with 415.  Malformed HTTP (a negative `Content-Length`, ...)
  is 400 `malformed-http`; a request whose headers or body arrive too slowly is 408 `request-timeout`
  (`KFIO_HEADER_TIMEOUT_S`, `KFIO_BODY_TIMEOUT_S`), and a connection past `KFIO_MAX_CONNECTIONS` is 503
  `busy`; all three close the connection.
* Each request has a time budget (30 s by default, set per deployment with `KFIO_TIME_BUDGET_S`;
  a request may ask for less with `options.time_budget_s`, at least 0.01 s).  Past it the answer
  is 504; when no worker becomes free in time, 503 with `Retry-After` (an invalid body is 422 even
  then).  When the server is stopped (SIGTERM), running requests get a few seconds to finish, then
  they and every waiting request get 503 `shutting-down` with `Retry-After`.
* Each analysis process has a memory limit (`KFIO_MEMORY_MB`); a request that needs more is 422
  `memory-exceeded`.
* Identical requests (same canonical JSON) are answered from an in-memory cache (`X-Cache: hit`).
* Longer work runs as a job: `POST /v1/jobs/analyze`, `POST /v1/jobs/bounds`, `POST /v1/jobs/simulate`,
  `POST /v1/jobs/loop` and `POST /v1/jobs/fit` take the body of their command, and `POST /v1/sweeps` a sweep; each answers
  202 with a `Location` to poll; budgets up to an hour (`KFIO_JOB_TIME_BUDGET_S`), a separate lane of
  worker processes (`KFIO_JOB_WORKERS`), at most `KFIO_MAX_JOBS` waiting (429 beyond), `DELETE` cancels.
  `kfio serve` keeps jobs in an embedded database (`KFIO_DATA_DIR`): they run and answer after a restart.
* When the deployment sets access tokens (`KFIO_API_TOKEN`, `KFIO_API_TOKEN_FILE`; `kfio serve` generates one
  when it listens beyond loopback without any), every route but `/healthz`, the page and these docs needs
  `Authorization: Bearer <token>`: 401 otherwise.
* Requests are answered only for the host names the deployment trusts (`KFIO_TRUSTED_HOSTS`, loopback names
  by default); any other `Host` header is 421 `misdirected-request` (a defence against DNS rebinding).
* A web page for all of this is at `/`; these docs and the page load nothing from other hosts.
"""


def create_app(settings: Settings | None = None) -> FastAPI:
    """Build the app for ``settings`` (default: :func:`kfio.service.settings.get_settings`).

    The worker pool starts in the background when the app starts (``/readyz``
    says when it is up) and is killed when the app stops.
    """
    settings = settings if settings is not None else get_settings()

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        dispatcher = Dispatcher(settings)
        jobs = JobStore(settings)
        app.state.dispatcher, app.state.jobs = dispatcher, jobs
        starting = [asyncio.create_task(dispatcher.pool.start()), asyncio.create_task(jobs.start())]
        app.state.starting = starting  # kfio serve stops (exit 6) if a pool cannot start
        try:
            yield
        finally:
            await dispatcher.pool.close()
            await jobs.close()
            dispatcher.close()
            # they see the pools closed and stop their last workers; a start error was logged
            await asyncio.gather(*starting, return_exceptions=True)
            app.state.dispatcher = app.state.jobs = None

    app = FastAPI(
        title="kfio", version=API_VERSION, description=DESCRIPTION, lifespan=lifespan, docs_url=None, redoc_url=None
    )
    tokens = configured_tokens(settings)
    if tokens:  # 401 without a bearer token; inside HostCheck, so an untrusted Host is 421 first
        app.add_middleware(BearerAuth, tokens=tokens)
    app.add_middleware(HostCheck, hosts=parse_hosts(settings.trusted_hosts))  # 421 for untrusted Host names
    app.add_middleware(ChunkedResponses)  # a slow reader holds a piece of a large response, not all of it
    app.include_router(api_router)
    web.install(app)  # /, /docs, /redoc: every asset from the package, none from another host
    for exc in (ProblemError, AnalyzerError, RequestValidationError, StarletteHTTPException, Exception):
        app.add_exception_handler(exc, problem_handler)
    app.add_exception_handler(ClientDisconnect, disconnect_handler)  # an info line, not "internal error"

    def openapi() -> dict[str, Any]:
        if app.openapi_schema is None:
            schema = get_openapi(title=app.title, version=app.version, description=app.description, routes=app.routes)
            schema.setdefault("components", {}).setdefault("schemas", {}).update(COMPONENTS)
            app.openapi_schema = declare_security(schema)
        return app.openapi_schema

    app.openapi = openapi  # type: ignore[method-assign]
    return app
