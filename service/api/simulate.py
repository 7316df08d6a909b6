"""``POST /v1/simulate``: Monte Carlo error bands, as ``kfio simulate --json``."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import Response

from .deps import BodyDep, DispatcherDep
from .schemas import REQUEST_EXAMPLES, json_body, json_response, problem_responses

router = APIRouter(tags=["analysis"])


@router.post(
    "/v1/simulate",
    summary="Simulated error covariance bands",
    description="Takes exactly the JSON of `kfio simulate FILE` and returns exactly its `--json` report.",
    response_class=Response,
    responses={**json_response("SimulationReport", "The simulation report"), **problem_responses(413, 422, 501, 503, 504)},
    openapi_extra=json_body(REQUEST_EXAMPLES),
)
async def simulate(body: BodyDep, dispatcher: DispatcherDep) -> Response:
    return await dispatcher.answer("simulate", body, {})
