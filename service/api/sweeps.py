"""``POST /v1/sweeps``: a sweep (``kfio sweep``'s request) run as a job.

The sweep's shape (axes, pointers, point count) is checked before it is
queued, in time linear in the body: a 422 at once.  The points themselves are
validated by the job's worker process, never by the server: a bad point fails
the job with a 422 problem naming ``/points/<index>/<field>``.
The job is then polled at ``/v1/jobs/{id}`` (status, ``progress.fraction`` =
points done), and its result is the table as JSON.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from fastapi import APIRouter
from fastapi.responses import Response

from kfio.model import option_fields
from kfio.sweep import MAX_AXIS_VALUES

from .deps import BodyDep
from .jobs import STATUS_RESPONSE, JobStoreDep, accepted, validated
from .schemas import option_schema, problem_responses

if TYPE_CHECKING:
    from kfio.sweep import SweepSpec

router = APIRouter(prefix="/v1/sweeps", tags=["sweeps"])

SWEEP_EXAMPLE = {
    "command": "analyze",
    "base": {
        "system": {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]], "Q": [[20, 0], [0, 20]], "R": [[2.5]]},
        "channel": {"model": "bernoulli", "arrival_probability": 0.5},
    },
    "axes": [{"pointer": "/channel/arrival_probability", "from": "3/10", "to": "9/10", "num": 61}],
    "combine": "grid",
}


SWEEP_SCHEMA: dict[str, Any] = {
    "type": "object",
    "description": "A sweep: a base request and axes, or a list of requests (see docs/sweeps.md).",
    "properties": {
        "command": {"enum": ["analyze", "bounds", "simulate", "loop"], "default": "analyze"},
        "base": {
            "description": "a request; a loop request (docs/loop.md) when `command` is `loop`",
            "anyOf": [{"$ref": "#/components/schemas/AnalysisRequest"}, {"$ref": "#/components/schemas/LoopRequest"}],
        },
        "axes": {
            "type": "array",
            "items": {
                "type": "object",
                "required": ["pointer"],
                "properties": {
                    "pointer": {"type": "string", "pattern": "^/", "description": "RFC 6901 pointer into `base`"},
                    "name": {"type": "string", "description": "column name (default: the pointer)"},
                    "values": {"type": "array", "minItems": 1},
                    "from": {"description": "exact number: first value of a range"},
                    "to": {"description": "exact number: last value of a range"},
                    "num": {"type": "integer", "minimum": 1, "maximum": MAX_AXIS_VALUES},
                },
                "additionalProperties": False,
            },
        },
        "combine": {"enum": ["grid", "zip"], "default": "grid"},
        "requests": {
            "type": "array",
            "minItems": 1,
            "items": {
                "anyOf": [
                    {"$ref": "#/components/schemas/AnalysisRequest"},
                    {"$ref": "#/components/schemas/LoopRequest"},
                ]
            },
        },
        "options": {
            "type": "object",
            "properties": {f.name: option_schema(f) for f in option_fields("sweep")},
            "additionalProperties": False,
        },
    },
    "additionalProperties": False,
}


#: The route's schema: the sweep's own fields as :data:`SWEEP_SCHEMA` says (the submit check reads
#: them), while ``base`` and each of ``requests`` are any object here: every point is validated by
#: the job's worker, so a bad request inside a sweep fails the job (422 naming ``/points/<i>/...``)
#: instead of being refused at submit. The published file schema (``sweep.json``) keeps the strict
#: request schemas, for editors.
SWEEP_ROUTE_SCHEMA: dict[str, Any] = {
    **SWEEP_SCHEMA,
    "properties": {
        **SWEEP_SCHEMA["properties"],
        "base": {
            "type": "object",
            "description": "a request (AnalysisRequest; a LoopRequest when `command` is `loop`), validated with "
            "the axes applied, point by point, by the job's worker",
        },
        "requests": {
            "type": "array",
            "minItems": 1,
            "items": {"type": "object"},
            "description": "whole requests, each validated by the job's worker",
        },
    },
}


def _check_shape(body: bytes, max_points: int) -> SweepSpec:
    """The sweep's shape and size: O(body) work, safe in the server process.

    The point count comes from the axes' sizes before anything is built
    (:func:`kfio.sweep.sweep_size`); the points themselves are validated by
    the job's worker, under the job's budget and memory limit.
    """
    from kfio.sweep import load_sweep

    return load_sweep(body, max_points)


@router.post(
    "",
    status_code=202,
    summary="Run a sweep (grid or zip of a base request, or a list of requests) as a job",
    description=(
        "The body is a sweep: `command` (`analyze`, `bounds`, `simulate` or `loop`), `base` (a request; a loop "
        "request for `loop`) and `axes` "
        "(each a JSON pointer into the request with `values`, or `from`, `to`, `num` for exactly spaced rationals), "
        "`combine` (`grid` or `zip`); or `requests` (a list of whole requests), or JSON Lines of requests.  "
        "The shape and point count are checked before the job is queued (422 at once); every point is then "
        "validated by the job's worker before any work starts: a bad one fails the job with a 422 problem "
        "naming `/points/<index>/<field>`.  Answers 202 with "
        "`Location: /v1/jobs/{id}`; poll it for `progress.fraction` (points done) and the result: "
        "`{command, points, errors, columns, rows: [...]}`, one row per point with its coordinates and the "
        "report's key fields (or its error).  Runs in the job lane, or on the Dask cluster the deployment "
        "names (`KFIO_DASK_SCHEDULER`)."
    ),
    response_class=Response,
    responses={
        202: {"description": "The sweep was queued", **STATUS_RESPONSE},
        **problem_responses(413, 422, 429, 503),  # 503 server-misconfigured: KFIO_DASK_SCHEDULER does not work
    },
    openapi_extra={
        "requestBody": {
            "required": True,
            "content": {
                "application/json": {
                    "schema": SWEEP_ROUTE_SCHEMA,
                    "examples": {
                        "channel-sweep": {
                            "summary": "the 2x2 example of Sinopoli et al. (2004)",
                            "value": SWEEP_EXAMPLE,
                        }
                    },
                }
            },
        }
    },
)
async def submit_sweep(body: BodyDep, store: JobStoreDep) -> Response:
    settings = store.settings
    if settings.dask_scheduler:
        from ..sweep_jobs import dask_missing, misconfigured

        missing = dask_missing()
        if missing is not None:
            raise misconfigured("KFIO_DASK_SCHEDULER", missing)
    spec = await validated(_check_shape, body, settings.max_sweep_points)
    # the body may be JSON Lines of requests (as for `kfio sweep`): the store is given the options, not the text
    options = {} if spec.time_budget_s is None else {"time_budget_s": repr(spec.time_budget_s)}
    return accepted(store, store.submit("sweep", body, tree={"options": options}))


__all__ = ["router"]
