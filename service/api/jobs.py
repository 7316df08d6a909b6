"""``/v1/jobs``: the report endpoints as jobs (queued, polled, cancelled), for work past the synchronous budget.

``POST /v1/jobs/analyze`` (``bounds``, ``simulate``) takes the body of the
synchronous endpoint and answers 202 with a ``Location``; ``GET
/v1/jobs/{id}`` gives the status, progress and, once finished, the report or
the problem; ``GET /v1/jobs/{id}/result`` the report's exact bytes;
``DELETE /v1/jobs/{id}`` cancels.  The store is :mod:`kfio.service.jobstore`.
"""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Depends, Path, Request
from fastapi.responses import Response

from kfio import load_json

from ..dispatch import INLINE_PARSE_BYTES, Dispatcher
from ..jobstore import Job, JobStore
from ..problems import Problem, ProblemError, problem_from_exception
from .deps import BodyDep, DispatcherDep
from .schemas import REQUEST_EXAMPLES, json_body, problem_responses

router = APIRouter(prefix="/v1/jobs", tags=["jobs"])

JOB_STATUS_SCHEMA: dict[str, Any] = {
    "type": "object",
    "description": (
        "A job's state.  `result` (the report of the synchronous endpoint) is present once `status` is `done`, "
        "`problem` (a problem document) once it is `failed`.  `progress` is set where the work reports it: "
        "`stage`, `steps` (budget check-ins so far), `elapsed_s`, and for simulations `fraction` (0 to 1)."
    ),
    "required": ["id", "kind", "status", "budget_s", "created_at", "links"],
    "properties": {
        "id": {"type": "string"},
        "kind": {"type": "string", "examples": ["analyze"]},
        "status": {"enum": ["queued", "running", "done", "failed", "cancelled"]},
        "budget_s": {"type": "number", "description": "wall-clock budget, counted from when the job starts running"},
        "created_at": {"type": "string", "format": "date-time"},
        "started_at": {"type": ["string", "null"], "format": "date-time"},
        "finished_at": {"type": ["string", "null"], "format": "date-time"},
        "progress": {"type": ["object", "null"]},
        "attempts": {
            "type": "integer",
            "description": "runs started so far (a restart of the server may re-run a job)",
        },
        "retention_s": {
            "type": ["number", "null"],
            "description": "how long the result is kept once the job finishes (`KFIO_JOB_RETENTION_S`)",
        },
        "expires_at": {
            "type": ["string", "null"],
            "format": "date-time",
            "description": "when the finished job is forgotten at the latest (null until it finishes)",
        },
        "links": {"type": "object", "properties": {"self": {"type": "string"}, "result": {"type": "string"}}},
        "result": {"type": "object", "description": "the report, exactly as the synchronous endpoint returns it"},
        "problem": {"$ref": "#/components/schemas/Problem"},
    },
}

STATUS_RESPONSE = {"content": {"application/json": {"schema": JOB_STATUS_SCHEMA}}}
JobId = Annotated[str, Path(description="the id from the `Location` of `POST /v1/jobs/...`", max_length=64)]


def get_jobstore(request: Request) -> JobStore:
    """The app's job store (created by the lifespan; 503 before it runs)."""
    store: JobStore | None = getattr(request.app.state, "jobs", None)
    if store is None:
        raise ProblemError(Problem(503, "not-ready", "Service not ready", "the service is starting", retry_after=1))
    return store


JobStoreDep = Annotated[JobStore, Depends(get_jobstore)]


async def validated(check: Any, *args: Any) -> Any:
    """Run ``check(*args)`` (a validator) in a thread, off the event loop, before a job is queued; its value.

    A bad request is a 422 naming the field at once, as on the synchronous
    endpoint, instead of a job that fails later.
    """
    import asyncio

    from ..problems import problem_from_exception

    try:
        return await asyncio.to_thread(check, *args)
    except ProblemError:
        raise
    except Exception as exc:  # noqa: BLE001 - InvalidInput and friends become their problem document
        problem = problem_from_exception(exc)
        if problem.status >= 500:
            raise
        raise ProblemError(problem) from None


#: Seconds a job's submit-time check may take in the synchronous lane, waiting for a worker included.
CHECK_BUDGET_S = 5.0


async def checked_in_worker(dispatcher: Dispatcher, kind: str, body: bytes) -> None:
    """Validate and size a job's request before it is queued, as the synchronous lane validates a request.

    The check (:func:`kfio.service.jobs.check_job_request`: exact validation,
    whose cost grows with the matrices) runs in a worker of the synchronous
    lane, within :data:`CHECK_BUDGET_S` (waiting included), never in the server
    process; only when that lane stays full does it run in the dispatcher's
    parse threads, as the synchronous endpoints do before they answer 503.  A
    check that outlasts its budget, or a worker that dies, leaves the job to
    validate itself (it then fails with the 422 problem).

    Raises
    ------
    ProblemError
        The 422 problem (or 503 while shutting down) the synchronous twin would give.
    """
    from ..jobs import check_job_request
    from ..pool import PoolBusy, PoolError, PoolShuttingDown

    settings = dispatcher.settings
    try:
        budget = min(settings.time_budget_s, CHECK_BUDGET_S)
        outcome = await dispatcher.pool.run(("check-job", body, settings, {"kind": kind}), budget)
    except PoolShuttingDown as exc:
        raise ProblemError(problem_from_exception(exc)) from None
    except PoolBusy:
        try:
            await dispatcher._off_loop(check_job_request, kind, body, settings)
        except Exception as exc:  # noqa: BLE001 - InvalidInput and friends become their problem document
            problem = problem_from_exception(exc)
            if problem.status >= 500:
                raise
            raise ProblemError(problem) from None
        return
    except PoolError:
        return  # past a request's budget, or the worker died: the job has its own budget and validates itself
    if outcome[0] != "ok":
        problem = Problem.from_dict(outcome[1])
        if problem.status == 422:
            raise ProblemError(problem)


def accepted(store: JobStore, job: Job) -> Response:
    """The ``202`` of every job route: the job's document, and ``Location`` to poll."""
    return Response(
        store.document(job), status_code=202, media_type="application/json", headers={"Location": f"/v1/jobs/{job.id}"}
    )


def _submit_route(kind: str) -> None:
    async def submit(body: BodyDep, store: JobStoreDep, dispatcher: DispatcherDep) -> Response:
        await checked_in_worker(dispatcher, kind, body)
        tree = await dispatcher._off_loop(load_json, body) if len(body) > INLINE_PARSE_BYTES else None
        return accepted(store, store.submit(kind, body, tree=tree))

    submit.__name__ = f"submit_{kind}_job"
    router.add_api_route(
        f"/{kind}",
        submit,
        methods=["POST"],
        status_code=202,
        summary=f"Run `{kind}` as a job (budget up to an hour)",
        description=(
            f"Same body as `POST /v1/{kind}`.  Answers 202 with `Location: /v1/jobs/{{id}}` at once; poll that URL. "
            "The job runs in a separate lane of worker processes, with the deployment's job budget "
            "(`KFIO_JOB_TIME_BUDGET_S`, an hour by default) or less if `options.time_budget_s` asks for less.  "
            "The request is validated and sized before it is queued (422 naming the field), with the job lane's "
            "limits (a simulation job may do `KFIO_JOB_MAX_TRAJECTORY_STEPS` trajectory-steps, 10^8 by default, "
            "where a request may do 10^6); option values that only the computation checks end the job `failed` "
            "with a 422 problem.  "
            "A `kfio serve` keeps its jobs in an embedded database (`KFIO_DATA_DIR`): queued and running jobs "
            "run after a restart, and the 202 says how long the result is kept (`retention_s`).  "
            "503 `store-unavailable` when the job cannot be written (a full disk): nothing was queued."
        ),
        response_class=Response,
        responses={
            202: {"description": "The job was queued", **STATUS_RESPONSE},
            **problem_responses(413, 422, 429, 503),
        },
        openapi_extra=json_body(REQUEST_EXAMPLES),
    )


for _kind in ("analyze", "bounds", "simulate"):
    _submit_route(_kind)


@router.get(
    "/{job_id}",
    summary="A job's status, progress, and result or problem",
    response_class=Response,
    responses={200: {"description": "The job", **STATUS_RESPONSE}, **problem_responses(404, 422)},
)
async def get_job(job_id: JobId, store: JobStoreDep) -> Response:
    return Response(store.document(store.get(job_id)), media_type="application/json")


@router.get(
    "/{job_id}/result",
    summary="A finished job's report, byte for byte as the synchronous endpoint answers",
    description="200 with the report once the job is `done`; a failed job answers its problem (with its status); "
    "409 while it is queued or running, or if it was cancelled.",
    response_class=Response,
    responses={
        200: {"description": "The report", "content": {"application/json": {"schema": {"type": "object"}}}},
        **problem_responses(404, 409, 422, 503, 504),
    },
)
async def get_job_result(job_id: JobId, store: JobStoreDep) -> Response:
    job = store.get(job_id)
    if job.status == "done" and job.content is not None:
        return Response(job.content, media_type=job.media_type)
    if job.status == "failed" and job.problem is not None:
        raise ProblemError(job.problem)
    raise ProblemError(Problem(409, "job-not-done", "Job has no result", f"job {job_id} is {job.status}"))


@router.delete(
    "/{job_id}",
    summary="Cancel a job (a running one's worker process is killed)",
    response_class=Response,
    responses={200: {"description": "The job, now cancelled", **STATUS_RESPONSE}, **problem_responses(404, 409, 422)},
)
async def cancel_job(job_id: JobId, store: JobStoreDep) -> Response:
    return Response(store.document(store.cancel(job_id)), media_type="application/json")
