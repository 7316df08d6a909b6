"""``GET /schemas/{name}.json``: the published JSON Schemas (draft 2020-12) of kfio's files.

The files are the package's ``kfio/service/schemas/*.json``, written by
``python -m kfio.service.schema_files`` (see that module); an unknown name is
a 404 problem.
"""

from __future__ import annotations

from fastapi import APIRouter, Request
from fastapi.responses import Response

from ..problems import Problem, ProblemError
from ..schema_files import DOCUMENTS, PACKAGE_DIR
from .schemas import problem_responses

router = APIRouter(prefix="/schemas", tags=["schemas"])

MEDIA_TYPE = "application/schema+json"


@router.get(
    "/{name}.json",
    summary="A published JSON Schema (draft 2020-12) of a kfio file",
    description="One of: " + ", ".join(f"`{n}`" for n in DOCUMENTS) + ". Each is self-contained (`$defs`); "
    "what JSON Schema cannot say is in `description`, and the validator names the field and the rule.",
    response_class=Response,
    openapi_extra={
        "parameters": [
            {
                "name": "name",
                "in": "path",
                "required": True,
                "description": "the schema's name (an unknown name is a 404 problem)",
                "schema": {"type": "string", "examples": ["request", "check"]},
            }
        ]
    },
    responses={
        200: {"description": "The schema", "content": {MEDIA_TYPE: {"schema": {"type": "object"}}}},
        **problem_responses(404),
    },
)
async def schema_file(request: Request) -> Response:
    # the name is read from the path, not declared as a parameter: nothing here can fail validation (422)
    name = request.path_params["name"]
    if name not in DOCUMENTS:
        raise ProblemError(
            Problem(404, "http-404", "Not Found", f"no schema named {name!r}; the schemas are {sorted(DOCUMENTS)}")
        )
    return Response((PACKAGE_DIR / f"{name}.json").read_bytes(), media_type=MEDIA_TYPE)
