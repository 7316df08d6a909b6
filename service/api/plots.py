"""``POST /v1/plots/...``: PNG figures, drawn in a worker (matplotlib, Agg backend).

The body is the same request JSON as for the analysis endpoints; plot
settings are query parameters, so the body stays exactly the CLI's.
"""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Query
from fastapi.responses import Response

from ..problems import Problem, ProblemError
from .deps import BodyDep, DispatcherDep
from .loop_schemas import LOOP_EXAMPLES
from .schemas import (
    GE_REGION_EXAMPLES,
    PHASE_TRANSITION_EXAMPLES,
    REGION_EXAMPLES,
    REQUEST_EXAMPLES,
    json_body,
    problem_responses,
    schema_ref,
)

router = APIRouter(prefix="/v1/plots", tags=["plots"])

_PNG: dict[int | str, dict[str, Any]] = {
    200: {"description": "A PNG image", "content": {"image/png": {"schema": {"type": "string", "format": "binary"}}}}
}
_ERRORS = problem_responses(413, 415, 422, 503, 504)


@router.post(
    "/phase-transition",
    summary="Traces of S_bar and V_bar against lambda, critical values marked (Sinopoli et al. 2004, Figs. 1-3)",
    description=(
        "One packet over a Bernoulli channel.  Draws trace(S_bar) (lower bound on the limit of E[P]) and "
        "trace(V_bar) (upper bound) on a grid of arrival probabilities, with the lower bound "
        "1 - 1/rho(A)^2 and the LMI upper bound on lambda_c marked, and the request's own lambda."
    ),
    response_class=Response,
    responses={**_PNG, **_ERRORS},
    openapi_extra=json_body(PHASE_TRANSITION_EXAMPLES),
)
async def phase_transition(
    body: BodyDep,
    dispatcher: DispatcherDep,
    points: Annotated[int, Query(ge=2, le=400, description="grid points on the lambda axis")] = 100,
    lambda_min: Annotated[float | None, Query(ge=0, le=1, description="left end of the lambda axis")] = None,
    lambda_max: Annotated[float | None, Query(ge=0, le=1, description="right end of the lambda axis")] = None,
) -> Response:
    if lambda_min is not None and lambda_max is not None and lambda_min >= lambda_max:
        raise ProblemError(
            Problem(
                422,
                "invalid-input",
                "Invalid request",
                "/lambda_max: must exceed lambda_min",
                field="/lambda_max",
                rule="lambda_max must exceed lambda_min",
                location="query",
            )
        )
    params = {"points": points, "lambda_min": lambda_min, "lambda_max": lambda_max}
    return await dispatcher.answer("plot-phase-transition", body, params)


@router.post(
    "/region",
    summary="Stability region for two sensors (Liu and Goldsmith 2004, Figs. 4-5)",
    description=(
        "Two sensors over Bernoulli channels.  Colours the (lambda_1, lambda_2) square as the bounds report's "
        "region map does (unstable by the lower bound, stable by the LMI, undecided between them), marks kfio's "
        "exact verdict on every cell and draws the exact boundary lambda_2 = h(lambda_1) (an extension of "
        "Rohr, Marelli and Fu 2014), and marks the request's own point."
    ),
    response_class=Response,
    responses={**_PNG, **_ERRORS},
    openapi_extra=json_body(REGION_EXAMPLES),
)
async def region(
    body: BodyDep,
    dispatcher: DispatcherDep,
    points: Annotated[int, Query(ge=2, le=41, description="grid points per axis (options.bounds.grid)")] = 21,
) -> Response:
    return await dispatcher.answer("plot-region", body, {"points": points})


@router.post(
    "/ge-region",
    summary="Exact stability region of a Gilbert-Elliott channel in the (recovery, failure) square",
    description=(
        "One packet over a Gilbert-Elliott channel.  Colours every cell of the (q, p) square by the exact "
        "verdict of Theorem 1 (Rohr, Marelli and Fu, 2014) at its centre, draws the boundary "
        "|alpha_k|^2 sigma_k(p, q) = 1 piece by piece (one algebraic curve per FMO block and blind pattern), "
        "and marks the request's own point.  The same map is in the analyze report with options.analyze.ge_grid."
    ),
    response_class=Response,
    responses={**_PNG, **_ERRORS},
    openapi_extra=json_body(GE_REGION_EXAMPLES),
)
async def ge_region(
    body: BodyDep,
    dispatcher: DispatcherDep,
    points: Annotated[int, Query(ge=2, le=101, description="cells per axis (options.analyze.ge_grid)")] = 41,
) -> Response:
    return await dispatcher.answer("plot-ge-region", body, {"points": points})


@router.post(
    "/loop-region",
    summary="A closed loop's exact stable region over its two links, and its exact cost along each link",
    description=(
        "A loop request (as for `POST /v1/loop`) with one sensor link.  Top: every cell of the (sensor, actuator) "
        "square coloured by the loop's exact mean-square verdict at its centre (Costa, Fragoso and Marques 2005, "
        "Thm 3.9), the exact critical actuator arrival probability against the sensor's (Bernoulli links: the "
        "loop report's `region.boundary`), the report's critical values and the request's point.  Bottom: the "
        "exact stationary cost against each link's parameter, the other held at the request's value.  The "
        "title is the exact verdict at the request's point."
    ),
    response_class=Response,
    responses={**_PNG, **_ERRORS},
    openapi_extra={
        "requestBody": {
            "required": True,
            "content": {"application/json": {"schema": schema_ref("LoopRequest"), "examples": LOOP_EXAMPLES}},
        }
    },
)
async def loop_region(
    body: BodyDep,
    dispatcher: DispatcherDep,
    points: Annotated[int, Query(ge=2, le=41, description="cells per axis, and boundary points")] = 21,
) -> Response:
    return await dispatcher.answer("plot-loop-region", body, {"points": points})


@router.post(
    "/simulation",
    summary="Simulated error bands against time",
    description="Runs the same simulation as `POST /v1/simulate` and draws its bands against time.",
    response_class=Response,
    responses={**_PNG, **_ERRORS},
    openapi_extra=json_body(REQUEST_EXAMPLES),
)
async def simulation(body: BodyDep, dispatcher: DispatcherDep) -> Response:
    return await dispatcher.answer("plot-simulation", body, {})
