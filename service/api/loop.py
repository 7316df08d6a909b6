"""``POST /v1/loop`` and ``POST /v1/jobs/loop``: a closed loop's exact verdict, cost and critical probabilities.

Same body as ``kfio loop FILE`` (a loop request, ``docs/loop.md``), same bytes as its ``--json``.
"""

from __future__ import annotations

from fastapi import APIRouter, Request
from fastapi.responses import Response

from .deps import BodyDep, get_body, get_dispatcher
from .jobs import JobStoreDep, validated
from .loop_schemas import LOOP_EXAMPLES
from .schemas import json_response, problem_responses, schema_ref

router = APIRouter(tags=["analysis"])

_BODY = {
    "requestBody": {
        "required": True,
        "content": {"application/json": {"schema": schema_ref("LoopRequest"), "examples": LOOP_EXAMPLES}},
    }
}


async def loop(request: Request) -> Response:
    dispatcher = await get_dispatcher(request)
    return await dispatcher.answer("loop", await get_body(request, dispatcher), {})


router.add_api_route(
    "/v1/loop",
    loop,
    methods=["POST"],
    summary="Closed loop over lossy sensor and actuator links",
    description="The exact mean-square verdict of the loop (Costa, Fragoso and Marques 2005, Thm 3.9), its "
    "stationary cost and the critical arrival probability of each link.  Takes exactly the JSON of "
    "`kfio loop FILE` and returns exactly its `--json` report.",
    response_class=Response,
    responses={**json_response("LoopReport", "The loop report"), **problem_responses(413, 415, 422, 503, 504)},
    openapi_extra=_BODY,
)


async def submit_loop_job(body: BodyDep, store: JobStoreDep) -> Response:
    from kfio.fit import load_trace_loop_request

    await validated(load_trace_loop_request, body, store.settings.limits())
    job = store.submit("loop", body)
    return Response(
        store.document(job), status_code=202, media_type="application/json", headers={"Location": f"/v1/jobs/{job.id}"}
    )


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
