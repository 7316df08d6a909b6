"""The shape shared by the report endpoints: a request body in, the CLI's ``--json`` report out."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Request
from fastapi.responses import Response

from .deps import get_body, get_dispatcher
from .schemas import REQUEST_EXAMPLES, json_body, json_response, problem_responses


def report_router(
    path: str,
    job: str,
    schema: str,
    summary: str,
    description: str,
    *,
    body: dict[str, Any] | None = None,
    router: APIRouter | None = None,
) -> APIRouter:
    """``router`` (a new one by default) with ``POST path`` answering job ``job`` with a ``schema`` report.

    ``body`` is the OpenAPI request body (default: the analysis request and its examples).
    """
    router = router or APIRouter(tags=["analysis"])

    async def endpoint(request: Request) -> Response:
        # the dependencies called directly: FastAPI's dependency solver was a tenth of a cached answer's CPU
        dispatcher = await get_dispatcher(request)
        return await dispatcher.answer(job, await get_body(request, dispatcher), {})

    endpoint.__name__ = job  # the OpenAPI operationId derives from it
    router.add_api_route(
        path,
        endpoint,
        methods=["POST"],
        summary=summary,
        description=f"{description} Takes exactly the JSON of `kfio {job} FILE` and returns exactly its `--json` report.",
        response_class=Response,
        responses={**json_response(schema, f"The {job} report"), **problem_responses(413, 415, 422, 503, 504)},
        openapi_extra=json_body(REQUEST_EXAMPLES) if body is None else body,
    )
    return router
