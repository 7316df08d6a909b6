"""The shape shared by the report endpoints: a request body in, the CLI's ``--json`` report out."""

from __future__ import annotations

from fastapi import APIRouter, Request
from fastapi.responses import Response

from .deps import get_body, get_dispatcher
from .schemas import REQUEST_EXAMPLES, json_body, json_response, problem_responses


def report_router(path: str, job: str, schema: str, summary: str, description: str) -> APIRouter:
    """A router with ``POST path`` answering job ``job`` with a ``schema`` report."""
    router = APIRouter(tags=["analysis"])

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
        openapi_extra=json_body(REQUEST_EXAMPLES),
    )
    return router
