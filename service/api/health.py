"""``GET /healthz`` (liveness) and ``GET /readyz`` (the worker pool is up)."""

from __future__ import annotations

from fastapi import APIRouter, Request
from fastapi.responses import JSONResponse

from ..problems import Problem, ProblemError
from .deps import DispatcherDep
from .schemas import json_response, problem_responses

router = APIRouter(tags=["health"])


@router.get(
    "/healthz",
    summary="Liveness: the event loop answers",
    description="Touches neither the worker pool nor the cache, so it answers at once even when every worker is busy.",
    response_class=JSONResponse,
    responses=json_response("Health", "The process is alive"),
)
async def healthz() -> JSONResponse:
    return JSONResponse({"status": "ok"})


@router.get(
    "/readyz",
    summary="Readiness: the worker pool is running",
    response_class=JSONResponse,
    responses={**json_response("Readiness", "Ready to take requests"), **problem_responses(503)},
)
async def readyz(request: Request, dispatcher: DispatcherDep) -> JSONResponse:
    if not dispatcher.pool.ready:
        raise ProblemError(
            Problem(503, "not-ready", "Service not ready", "the worker pool is not running yet", retry_after=1)
        )
    body = {"status": "ready", "pool": dispatcher.pool.stats(), "cache": dispatcher.cache.stats()}
    jobs = getattr(request.app.state, "jobs", None)
    if jobs is not None:
        body["jobs"] = jobs.stats()
    return JSONResponse(body)
