"""``POST /v1/loop`` and ``POST /v1/jobs/loop``: a closed loop's exact verdict, cost and critical probabilities.

Same body as ``kfio loop FILE`` (a loop request, ``docs/loop.md``), same bytes as its ``--json``.
"""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import Response

from .deps import BodyDep
from .jobs import JobStoreDep, accepted, validated
from .loop_schemas import LOOP_EXAMPLES
from .report import report_router
from .schemas import problem_responses, schema_ref

router = APIRouter(tags=["analysis"])

_BODY = {
    "requestBody": {
        "required": True,
        "content": {"application/json": {"schema": schema_ref("LoopRequest"), "examples": LOOP_EXAMPLES}},
    }
}


report_router(
    "/v1/loop",
    job="loop",
    schema="LoopReport",
    summary="Closed loop over lossy sensor and actuator links",
    description="The exact mean-square verdict of the loop (Costa, Fragoso and Marques 2005, Thm 3.9), its "
    "stationary cost and the critical arrival probability of each link.",
    body=_BODY,
    router=router,
)


async def submit_loop_job(body: BodyDep, store: JobStoreDep) -> Response:
    from kfio.fit import load_trace_loop_request

    await validated(load_trace_loop_request, body, store.settings.limits())
    return accepted(store, store.submit("loop", body))


router.add_api_route(
    "/v1/jobs/loop",
    submit_loop_job,
    methods=["POST"],
    status_code=202,
    tags=["jobs"],
    summary="Run `loop` as a job (budget up to an hour)",
    description="Same body as `POST /v1/loop`.  Answers 202 with `Location: /v1/jobs/{id}` at once; poll that URL "
    "(see `POST /v1/jobs/analyze`).",
    response_class=Response,
    responses={202: {"description": "The job was queued"}, **problem_responses(413, 422, 429, 503)},
    openapi_extra=_BODY,
)
