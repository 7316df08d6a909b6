"""``POST /v1/analyze``: the exact stability verdict, as ``kfio analyze --json`` prints it."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import Response

from .deps import BodyDep, DispatcherDep
from .schemas import REQUEST_EXAMPLES, json_body, json_response, problem_responses

router = APIRouter(tags=["analysis"])


@router.post(
    "/v1/analyze",
    summary="Exact stability verdict (seed 001, Theorem 1)",
    description=(
        "Decides whether the expected error covariance of the Kalman filter stays bounded. "
        "Takes exactly the JSON of `kfio analyze FILE` and returns exactly its `--json` report."
    ),
    response_class=Response,
    responses={**json_response("StabilityReport", "The stability report"), **problem_responses(413, 422, 501, 503, 504)},
    openapi_extra=json_body(REQUEST_EXAMPLES),
)
async def analyze(body: BodyDep, dispatcher: DispatcherDep) -> Response:
    return await dispatcher.answer("analyze", body, {})
