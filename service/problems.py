"""Errors as ``application/problem+json`` (RFC 9457), mapped in one place.

Every error the service answers with, whether raised in a worker process or
in the event loop, becomes a :class:`Problem`.  :func:`problem_from_exception`
is the single mapping from exceptions to problems (workers use it too, and
send the problem back, because analyzer exceptions do not pickle), and
:func:`problem_handler` is the single exception handler of the app.

=========================  ======  ===========================================
exception                  status  type (``urn:kfio:problem:...``)
=========================  ======  ===========================================
``InvalidInput``           422     ``invalid-input``
``LimitExceeded``          422     ``limit-exceeded``
``AssumptionViolation``    422     ``assumption-violation``
``NumericalFailure``       422     ``numerical-failure``
``MissingDependency``      503     ``missing-dependency`` (the deployment lacks a package)
``BudgetExceeded``         504     ``budget-exceeded``
``PoolTimeout``            504     ``budget-exceeded`` (the worker was killed)
``PoolShuttingDown``       503     ``shutting-down`` (with ``Retry-After``)
``PoolBusy``               503     ``busy`` (with ``Retry-After``)
``MemoryError``            422     ``memory-exceeded`` (the worker is replaced)
``WorkerOutOfMemory``      422     ``memory-exceeded`` (died in C code at its limit)
``WorkerCrashed``          503     ``worker-crashed`` (with ``Retry-After``)
anything else              500     ``internal`` (a bug; logged, never detailed)
=========================  ======  ===========================================
"""

from __future__ import annotations

import logging
from dataclasses import asdict, dataclass
from typing import Any

from fastapi import Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse, Response
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.routing import Match

from kfio.errors import (
    AnalyzerError,
    AssumptionViolation,
    BudgetExceeded,
    InvalidInput,
    LimitExceeded,
    MissingDependency,
    NumericalFailure,
    clip,
    clip_pointer,
)
from kfio.model import escaped, json_pointer

from .pool import PoolBusy, PoolShuttingDown, PoolTimeout, WorkerCrashed, WorkerOutOfMemory

log = logging.getLogger("kfio.service")

MEDIA_TYPE = "application/problem+json"
_PREFIX = "urn:kfio:problem:"
#: Characters of each text member of a problem document at most: every error body stays small, whatever
#: raised it (an ``InvalidInput`` bounds its field and rule itself; this also bounds every other message).
TEXT_LIMIT = 4096


@dataclass(frozen=True)
class Problem:
    """One problem document.

    Attributes
    ----------
    status:
        HTTP status code.
    kind:
        Short slug; the document's ``type`` is ``urn:kfio:problem:<kind>``.
    title:
        Fixed, human-readable summary of the kind.
    detail:
        What happened to this request.
    field:
        JSON pointer (RFC 6901) to the offending value, for input errors.
    rule:
        The rule that was broken, for input errors.
    location:
        ``"body"`` or ``"query"``: where ``field`` points.
    retry_after:
        Seconds after which a retry may succeed (sent as ``Retry-After``).
    partial:
        What a computation cut short by its budget had proved
        (:attr:`kfio.errors.BudgetExceeded.partial`), sent as extension members.
    """

    status: int
    kind: str
    title: str
    detail: str
    field: str | None = None
    rule: str | None = None
    location: str | None = None
    retry_after: int | None = None
    partial: dict[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        """The JSON document (members that are ``None`` are left out)."""
        # escaped: a field pointer or rule may quote user text, which must not break the encoder
        doc: dict[str, Any] = {
            "type": _PREFIX + self.kind,
            "title": self.title,
            "status": self.status,
            "detail": clip(escaped(self.detail), TEXT_LIMIT),
        }
        for key in ("field", "rule"):
            if getattr(self, key) is not None:
                doc[key] = clip(escaped(getattr(self, key)), TEXT_LIMIT)
        if self.location is not None:
            doc["in"] = self.location
        if self.partial is not None:
            doc.update(self.partial)  # extension members (RFC 9457, section 3.2)
        return doc

    def response(self) -> JSONResponse:
        """The HTTP response carrying this problem."""
        headers = {"Retry-After": str(self.retry_after)} if self.retry_after is not None else None
        return JSONResponse(self.to_dict(), status_code=self.status, media_type=MEDIA_TYPE, headers=headers)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Problem:
        """Inverse of :func:`dataclasses.asdict` (problems travel from workers as dicts)."""
        return cls(**data)

    def as_plain(self) -> dict[str, Any]:
        """Picklable, dataclass-shaped dict (see :meth:`from_dict`)."""
        return asdict(self)


class ProblemError(Exception):
    """Raise to answer with ``problem``."""

    def __init__(self, problem: Problem) -> None:
        super().__init__(problem.detail)
        self.problem = problem


#: ``Retry-After`` of a refusal while the server shuts down (a restarted server takes a few seconds).
SHUTDOWN_RETRY_AFTER_S = 5

#: Problem kind of a job that ran out of memory (its worker is retired).
MEMORY_EXCEEDED = "memory-exceeded"


def input_problem(kind: str, title: str, exc: InvalidInput) -> Problem:
    return Problem(422, kind, title, f"{exc.field}: {exc.rule}", field=exc.field, rule=exc.rule, location="body")


def problem_from_exception(exc: BaseException) -> Problem:
    """Map any exception to its problem (see the table in the module docstring).

    Examples
    --------
    >>> problem_from_exception(InvalidInput("/system/A", "A must be square")).status
    422
    """
    if isinstance(exc, ProblemError):
        return exc.problem
    if isinstance(exc, AssumptionViolation):
        return input_problem("assumption-violation", "Outside the hypotheses of the theorem", exc)
    if isinstance(exc, LimitExceeded):
        return input_problem("limit-exceeded", "Request exceeds a size limit", exc)
    if isinstance(exc, InvalidInput):
        return input_problem("invalid-input", "Invalid request", exc)
    if isinstance(exc, BudgetExceeded):
        return Problem(
            504,
            "budget-exceeded",
            "Time budget exceeded",
            f"the computation did not finish within its budget: {exc}",
            partial=exc.partial,
        )
    if isinstance(exc, PoolTimeout):
        return Problem(504, "budget-exceeded", "Time budget exceeded", str(exc))
    if isinstance(exc, PoolShuttingDown):
        return Problem(503, "shutting-down", "Service shutting down", str(exc), retry_after=SHUTDOWN_RETRY_AFTER_S)
    if isinstance(exc, PoolBusy):
        return Problem(503, "busy", "Service busy", str(exc), retry_after=1)
    if isinstance(exc, WorkerOutOfMemory):
        return Problem(422, MEMORY_EXCEEDED, "Memory limit exceeded", str(exc))
    if isinstance(exc, WorkerCrashed):
        return Problem(503, "worker-crashed", "Worker process died", str(exc), retry_after=1)
    if isinstance(exc, MemoryError):
        return Problem(
            422,
            MEMORY_EXCEEDED,
            "Memory limit exceeded",
            "the computation needs more memory than this deployment allows one analysis process "
            "(KFIO_MEMORY_MB); a smaller request, or a larger limit, is needed",
        )
    if isinstance(exc, NumericalFailure):
        return Problem(422, "numerical-failure", "Numerical step could not be certified", str(exc))
    if isinstance(exc, MissingDependency):
        return Problem(503, "missing-dependency", "A package this feature needs is not installed", str(exc))
    if isinstance(exc, AnalyzerError):
        return Problem(422, "analysis-error", "The analysis could not be completed", str(exc))
    return Problem(
        500, "internal", "Internal error", "an unexpected error occurred (this is a bug; it has been logged)"
    )


#: Methods a 405's ``Allow`` may list.
_METHODS = ("DELETE", "GET", "HEAD", "PATCH", "POST", "PUT")


def allowed_methods(request: Request) -> str:
    """The ``Allow`` header of a 405: every method some route answers on the request's path (RFC 9110, 15.5.6).

    Starlette's own header names the methods of the first route on the path
    only (``GET`` for ``/v1/jobs/{id}``, which ``DELETE`` serves too), so each
    method is tried against the app's routes with Starlette's own matching.
    """
    routes = request.app.router.routes
    allowed = [m for m in _METHODS if any(r.matches({**request.scope, "method": m})[0] is Match.FULL for r in routes)]
    return ", ".join(allowed)


async def disconnect_handler(request: Request, exc: Exception) -> Response:
    """A client that went away before its body was read: one info line, no traceback (it is not a bug).

    The answer goes nowhere; it is there because a handler must return one.
    """
    log.info("client disconnected before its request body was read: %s %s", request.method, request.url.path)
    return Response(status_code=400)


async def problem_handler(request: Request, exc: Exception) -> JSONResponse:
    """The app's one exception handler: every error becomes problem+json."""
    if isinstance(exc, RequestValidationError):
        err = exc.errors()[0] if exc.errors() else {"loc": (), "msg": "invalid request"}
        loc = tuple(err.get("loc", ()))
        where, rest = (str(loc[0]), loc[1:]) if loc else ("body", ())
        field, rule = clip_pointer(json_pointer(rest)), clip(str(err.get("msg")), TEXT_LIMIT // 2)
        problem = Problem(
            422, "invalid-input", "Invalid request", f"{field}: {rule}", field=field, rule=rule, location=where
        )
    elif isinstance(exc, StarletteHTTPException):
        problem = Problem(exc.status_code, f"http-{exc.status_code}", str(exc.detail), str(exc.detail))
        response = problem.response()
        response.headers.update(exc.headers or {})
        if exc.status_code == 405:  # Starlette names the methods of one route only; a path may have several
            response.headers["Allow"] = allowed_methods(request)
        return response
    else:
        problem = problem_from_exception(exc)
        if problem.status >= 500 and problem.kind == "internal":
            log.error("internal error on %s %s", request.method, request.url.path, exc_info=exc)
    return problem.response()
