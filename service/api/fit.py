"""``POST /v1/fit``: a channel model for a measured packet trace, as ``kfio fit --json`` prints it.

The body is ``{"arrivals": "0110..." or [0, 1, ...], "level": 0.95}`` (optional
``model``, ``order``, ``max_order``); the answer the :class:`kfio.fit.FitReport`.
Its component schemas are merged into the service's on import, as the loop's are.
"""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Request
from fastapi.responses import Response

from kfio.fit import MAX_ORDER
from kfio.model import MAX_NUMBER_TEXT

from ..._version import __version__
from .deps import BodyDep, get_body, get_dispatcher
from .jobs import STATUS_RESPONSE, JobStoreDep, accepted, validated
from .schemas import COMPONENTS, json_response, problem_responses, schema_ref

FIT_EXAMPLE: dict[str, Any] = {"arrivals": "1101101110110111011011101101", "level": 0.95}

TRACE_REQUEST: dict[str, Any] = {
    "system": {"A": [[-1.25]], "C": [[1]]},
    "channel": {"model": "trace", "arrivals": "1101100111011101101001110110111011", "level": 0.95},
}

_INTERVALS = {
    "type": "object",
    "additionalProperties": {"type": "array", "items": {"type": "number"}, "minItems": 2, "maxItems": 2},
}

_LEVEL = {
    "description": "joint confidence level in (0, 1), exact from its decimal text (default 0.95)",
    "anyOf": [
        {"type": "number", "exclusiveMinimum": 0, "exclusiveMaximum": 1},
        {"type": "string", "maxLength": MAX_NUMBER_TEXT},
    ],
}

FIT_COMPONENTS: dict[str, dict[str, Any]] = {
    "FitRequest": {
        "type": "object",
        "description": "A packet trace (1 = arrived, 0 = lost) to fit a channel model to: Bernoulli, Gilbert-Elliott "
        "(Gilbert 1960; Elliott 1963) or a Markov chain of order 2..max_order (Yajnik, Moon, Kurose and Towsley "
        "1999), chosen by BIC (Schwarz 1978). See docs/traces.md.",
        "properties": {
            "arrivals": {
                "description": "the trace: a string of 0 and 1 characters, or an array of 0 and 1",
                "anyOf": [
                    {"type": "string", "pattern": "^[01]+$", "minLength": 2},
                    {"type": "array", "items": {"enum": [0, 1]}, "minItems": 2},
                ],
            },
            "level": _LEVEL,
            "model": {
                "enum": ["bernoulli", "gilbert_elliott", "markov"],
                "description": "fit this model instead of choosing by BIC (markov needs order)",
            },
            "order": {
                "type": "integer",
                "minimum": 2,
                "maximum": MAX_ORDER,
                "description": "with model markov: its order",
            },
            "max_order": {
                "type": "integer",
                "minimum": 0,
                "maximum": MAX_ORDER,
                "description": "largest Markov order tried (default 4)",
            },
        },
        "required": ["arrivals"],
        "additionalProperties": False,
        "examples": [FIT_EXAMPLE],
    },
    "TraceChannel": {
        "type": "object",
        "description": "A measured trace in place of a channel (kfio analyze, kfio loop): kfio fits it (as POST "
        "/v1/fit does), analyzes the fitted channel and adds the fit block, the verdict of the whole confidence "
        "region at `level`.",
        "properties": {
            "model": {"const": "trace"},
            "arrivals": {
                "anyOf": [
                    {"type": "string", "pattern": "^[01]+$"},
                    {"type": "array", "items": {"enum": [0, 1]}},
                ]
            },
            "level": _LEVEL,
            "max_order": {"type": "integer", "minimum": 0, "maximum": MAX_ORDER},
        },
        "required": ["model", "arrivals"],
        "additionalProperties": False,
        "examples": [{"model": "trace", "arrivals": "0110111011", "level": 0.95}],
    },
    "FitReport": {
        "type": "object",
        "description": "The report of `kfio fit --json`: the chosen model, its exact maximum-likelihood parameters, "
        "their exact binomial intervals (Clopper and Pearson 1934), joint by Bonferroni at `level`, every "
        "candidate's BIC, the run-length check and the channel object ready for a request.",
        "properties": {
            "kfio_version": {"type": "string"},
            "model": {"enum": ["bernoulli", "gilbert_elliott", "markov"]},
            "order": {"type": "integer", "minimum": 0},
            "parameters": {"type": "object", "additionalProperties": {"type": "string"}},
            "intervals": _INTERVALS,
            "marginal_intervals": _INTERVALS,
            "level": {"type": "number"},
            "interval_method": {"type": "string"},
            "samples": {"type": "integer", "minimum": 1},
            "counts": {"type": "object"},
            "criterion": {"type": "string"},
            "scores": {"type": "array", "items": {"type": "object"}},
            "goodness_of_fit": {"type": "object"},
            "channel": {"type": "object"},
            "source": {"type": "string"},
            "sequence": {"type": ["object", "null"]},
            "warnings": {"type": "array", "items": {"type": "string"}},
            "notes": {"type": "array", "items": {"type": "string"}},
        },
        "required": ["kfio_version", "model", "order", "parameters", "intervals", "level", "samples", "channel"],
        "examples": [
            {
                "kfio_version": __version__,
                "model": "bernoulli",
                "order": 0,
                "parameters": {"arrival_probability": "3/4"},
                "intervals": {"arrival_probability": [0.476, 0.927]},
                "level": 0.95,
                "samples": 16,
                "channel": {"model": "bernoulli", "arrival_probability": "3/4"},
            }
        ],
    },
}

COMPONENTS.update(FIT_COMPONENTS)

router = APIRouter(tags=["analysis"])

#: The request body of both fit routes: a trace and a confidence level.
_BODY: dict[str, Any] = {
    "requestBody": {
        "required": True,
        "content": {
            "application/json": {
                "schema": schema_ref("FitRequest"),
                "examples": {"short-trace": {"summary": "A short trace as a 0/1 string", "value": FIT_EXAMPLE}},
            }
        },
    }
}


async def fit(request: Request) -> Response:
    dispatcher = await get_dispatcher(request)
    return await dispatcher.answer("fit", await get_body(request, dispatcher), {})


router.add_api_route(
    "/v1/fit",
    fit,
    methods=["POST"],
    summary="Fit a channel model to a measured packet trace",
    description="Exact maximum-likelihood Bernoulli, Gilbert-Elliott and Markov models of a 0/1 arrival trace, "
    "chosen by BIC (Schwarz 1978), with exact binomial intervals (Clopper and Pearson 1934) joint by Bonferroni "
    "and a chi-square check of the loss-run lengths.  Returns exactly what `kfio fit --json` prints.",
    response_class=Response,
    responses={**json_response("FitReport", "The fit report"), **problem_responses(413, 415, 422, 503, 504)},
    openapi_extra=_BODY,
)


async def trace_region(request: Request) -> Response:
    dispatcher = await get_dispatcher(request)
    return await dispatcher.answer("plot-trace-region", await get_body(request, dispatcher), {})


router.add_api_route(
    "/v1/plots/trace-region",
    trace_region,
    methods=["POST"],
    tags=["plots"],
    summary="The confidence region of a channel fitted to a trace, over the exact stable region",
    description="An analyze request whose channel is a measured trace.  Bernoulli: the arrival-probability axis "
    "split at the exact critical probability, the confidence interval over it.  Gilbert-Elliott: the exact (q, p) "
    "map and boundary (Rohr, Marelli and Fu 2014, Theorem 1) with the Bonferroni box and its corners' verdicts.  "
    "A Markov fit has no plot (422).",
    response_class=Response,
    responses={
        200: {
            "description": "A PNG image",
            "content": {"image/png": {"schema": {"type": "string", "format": "binary"}}},
        },
        **problem_responses(413, 415, 422, 503, 504),
    },
    openapi_extra={
        "requestBody": {
            "required": True,
            "content": {
                "application/json": {
                    "schema": schema_ref("AnalysisRequest"),
                    "examples": {"trace": {"summary": "A scalar plant and a short trace", "value": TRACE_REQUEST}},
                }
            },
        }
    },
)


def _checked(body: bytes) -> None:
    from kfio import load_json
    from kfio.fit import fit_request

    fit_request(load_json(body))


async def submit_fit_job(body: BodyDep, store: JobStoreDep) -> Response:
    await validated(_checked, body)  # a bad trace is a 422 naming the field at once, not a failed job
    return accepted(store, store.submit("fit", body))


router.add_api_route(
    "/v1/jobs/fit",
    submit_fit_job,
    methods=["POST"],
    status_code=202,
    tags=["jobs"],
    summary="Fit a long trace as a job",
    description="Same body as `POST /v1/fit`, for traces whose fit outlasts a request's budget.  Answers 202 with "
    "`Location: /v1/jobs/{id}` at once; poll that URL.  The trace is checked before the job is queued (422 naming "
    "the field).",
    response_class=Response,
    responses={202: {"description": "The job was queued", **STATUS_RESPONSE}, **problem_responses(413, 422, 429, 503)},
    openapi_extra=_BODY,
)

__all__ = ["FIT_COMPONENTS", "FIT_EXAMPLE", "router"]
