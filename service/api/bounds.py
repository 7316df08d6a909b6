"""``POST /v1/bounds``: bounds on the critical probability and on ``E[P]``, as ``kfio bounds --json``."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import Response

from .deps import BodyDep, DispatcherDep
from .schemas import REQUEST_EXAMPLES, json_body, json_response, problem_responses

router = APIRouter(tags=["analysis"])


@router.post(
    "/v1/bounds",
    summary="Bounds on the critical probability and on the expected covariance (seeds 000, 002, 004)",
    description="Takes exactly the JSON of `kfio bounds FILE` and returns exactly its `--json` report.",
    response_class=Response,
    responses={**json_response("BoundsReport", "The bounds report"), **problem_responses(413, 422, 501, 503, 504)},
    openapi_extra=json_body(REQUEST_EXAMPLES),
)
async def bounds(body: BodyDep, dispatcher: DispatcherDep) -> Response:
    return await dispatcher.answer("bounds", body, {})
