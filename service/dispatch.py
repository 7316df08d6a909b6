"""From a request body to an answer: cache, then the worker pool.

The event loop does only cheap work here: read the body (bounded) and look
up the cache.  Parsing the JSON and building its canonical text for the cache
key run on the loop for small bodies and in a small thread pool for large ones
(a 1 MiB body costs the loop nothing), and
validation and analysis run in a worker via :func:`kfio.service.jobs.run_job`.
Identical requests that arrive while the first is still computing wait for the
same computation.  A request the pool cannot take (busy, or a budget too
small to wait) is validated first, so an invalid body gets its 422, never a
503 that invites a retry.
"""

from __future__ import annotations

import asyncio
import json
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Mapping

from fastapi import Request
from fastapi.responses import Response

from kfio import InvalidInput, load_json, load_request

from .cache import AnswerCache, CachedAnswer, canonical_json
from .io import requested_budget
from .jobs import PRELOAD
from .lanes import is_cheap
from .pool import PoolBusy, PoolShuttingDown, WorkerPool
from .problems import MEMORY_EXCEEDED, Problem, ProblemError, problem_from_exception
from .settings import Settings

#: Threads that parse bodies and build cache keys (off the event loop).
PARSE_THREADS = 2

#: Bodies up to this size are parsed on the loop: a thread hop costs more than parsing them
#: (about 0.1 ms for a seed system), while a 1 MiB body would hold the loop for tens of ms.
INLINE_PARSE_BYTES = 16 * 1024


async def read_body(request: Request, limit: int) -> bytes:
    """The request body, refusing (413) anything over ``limit`` bytes.

    ``Content-Length`` is checked before reading; a body without it (chunked)
    is read chunk by chunk and refused as soon as it passes the limit, so an
    oversized body is never held in memory.
    """
    too_large = ProblemError(
        Problem(413, "too-large", "Request body too large", f"request bodies are limited to {limit} bytes")
    )
    declared = request.headers.get("content-length")
    if declared is not None and declared.strip().isdigit() and int(declared) > limit:
        raise too_large
    chunks: list[bytes] = []
    size = 0
    async for chunk in request.stream():
        size += len(chunk)
        if size > limit:
            raise too_large
        chunks.append(chunk)
    return b"".join(chunks)


def require_json(content_type: str | None) -> None:
    """Refuse (415) a body whose ``Content-Type`` is not ``application/json`` (or ``+json``).

    Browsers send ``text/plain``, form and multipart bodies cross-site without
    asking first; requiring JSON keeps such "simple" requests out.
    """
    media = (content_type or "").split(";", 1)[0].strip().lower()
    if media != "application/json" and not (media.startswith("application/") and media.endswith("+json")):
        raise ProblemError(
            Problem(
                415,
                "unsupported-media-type",
                "Unsupported media type",
                f"request bodies must be sent with Content-Type: application/json (got {media or 'none'!r})",
                field="Content-Type",
                rule="must be application/json",
                location="header",
            )
        )


def request_key(job: str, body: bytes, params: Mapping[str, Any]) -> tuple[str, float | None, bool]:
    """Cache key of a request, its ``options.time_budget_s``, and whether it is cheap by size
    (:func:`kfio.service.lanes.is_cheap`; CPU work: run it off the loop)."""
    tree = load_json(body)
    key = f"{job} {json.dumps(dict(params), sort_keys=True)} {canonical_json(tree)}"
    return key, requested_budget(tree), is_cheap(job, tree, len(body)) and not params


def retire_worker(result: Any) -> bool:
    """A worker that ran out of memory is replaced (its heap may be left fragmented)."""
    return isinstance(result, tuple) and result[0] == "problem" and result[1].get("kind") == MEMORY_EXCEEDED


def job_pool(settings: Settings, size: int, max_waiting: int, reserved: int = 0) -> WorkerPool:
    """A pool of ``size`` worker processes running :func:`kfio.service.jobs.run_job` (preloaded, memory-limited).

    The synchronous lane (:class:`Dispatcher`, with ``reserved`` workers for
    cheap requests, :mod:`kfio.service.lanes`) and the job lane
    (:class:`kfio.service.jobstore.JobStore`) are two such pools.
    """
    return WorkerPool(
        size,
        "kfio.service.jobs:run_job",
        preload=PRELOAD,
        max_waiting=max_waiting,
        kill_grace_s=settings.kill_grace_s,
        memory_bytes=settings.memory_bytes(),
        retire=retire_worker,
        reserved=reserved,
        reserved_budget_s=settings.lane_budget_s,
    )


class Dispatcher:
    """Answers job requests for one app: owns its worker pool and its cache."""

    def __init__(self, settings: Settings) -> None:
        self.settings = settings
        self.pool = job_pool(settings, settings.workers, settings.max_queue, reserved=settings.lane_workers)
        self._parser = ThreadPoolExecutor(PARSE_THREADS, thread_name_prefix="kfio-parse")
        self.cache = AnswerCache(settings.cache_entries, settings.cache_bytes)
        self._inflight: dict[str, asyncio.Task[CachedAnswer]] = {}

    async def answer(self, job: str, body: bytes, params: Mapping[str, Any]) -> Response:
        """The response for ``job`` on ``body`` (from the cache if it was answered before).

        Raises
        ------
        ProblemError
            Any failure, already mapped to its problem document.
        InvalidInput
            The body is not JSON (mapped to 422 by the app's handler).
        """
        if len(body) <= INLINE_PARSE_BYTES:
            key, asked, cheap = request_key(job, body, params)
        else:
            key, asked, cheap = await self._off_loop(request_key, job, body, params)
        hit = self.cache.get(key)
        if hit is not None:
            return Response(hit.content, media_type=hit.media_type, headers={"X-Cache": "hit"})
        task = self._inflight.get(key)
        if task is None:
            budget = min(self.settings.time_budget_s, asked or self.settings.time_budget_s)
            task = asyncio.get_running_loop().create_task(self._compute(key, job, body, params, budget, cheap))
            self._inflight[key] = task
            task.add_done_callback(lambda t: self._forget(key, t))
        # shield: a client that goes away does not cancel work others wait for
        answer = await asyncio.shield(task)
        return Response(answer.content, media_type=answer.media_type, headers={"X-Cache": "miss"})

    async def _off_loop(self, fn: Any, *args: Any) -> Any:
        return await asyncio.get_running_loop().run_in_executor(self._parser, fn, *args)

    def close(self) -> None:
        """Stop the parsing threads (the pool is closed by the app)."""
        self._parser.shutdown(wait=False, cancel_futures=True)

    def _forget(self, key: str, task: asyncio.Task[CachedAnswer]) -> None:
        self._inflight.pop(key, None)
        if not task.cancelled():
            task.exception()  # retrieved here: every waiter may have gone away

    async def _compute(
        self, key: str, job: str, body: bytes, params: Mapping[str, Any], budget: float, cheap: bool = False
    ) -> CachedAnswer:
        try:
            outcome = await self.pool.run((job, body, self.settings, dict(params)), budget, cheap=cheap)
        except PoolBusy as exc:
            if not isinstance(exc, PoolShuttingDown):
                await self._off_loop(self._validate, body, job)  # an invalid body is told so, not to retry
            raise ProblemError(problem_from_exception(exc)) from None
        except Exception as exc:  # noqa: BLE001 - pool failures are problems too
            raise ProblemError(problem_from_exception(exc)) from None
        if outcome[0] != "ok":
            raise ProblemError(Problem.from_dict(outcome[1]))
        answer = CachedAnswer(outcome[1], outcome[2])
        self.cache.put(key, answer)
        return answer

    def _validate(self, body: bytes, job: str = "analyze") -> None:
        """Raise the 422 problem of an invalid ``body`` (nothing if it is valid); a loop body is a loop request."""
        try:
            if job in ("loop", "plot-loop-region"):
                from kfio.fit import load_trace_loop_request

                load_trace_loop_request(body, self.settings.limits())
            elif job == "fit":
                from kfio.fit import fit_request

                fit_request(load_json(body))
            elif job == "analyze":
                from kfio.fit import load_trace_request

                load_trace_request(body, self.settings.limits(job))
            else:
                load_request(body, self.settings.limits(job))
        except InvalidInput as exc:
            raise ProblemError(problem_from_exception(exc)) from None
