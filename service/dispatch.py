"""From a request body to an answer: cache, then the worker pool.

The event loop does only cheap work here: read the body (bounded), parse its
JSON once for the cache key, look up the cache.  Validation and analysis run
in a worker via :func:`kfio.service.jobs.run_job`.  Identical requests that arrive
while the first is still computing wait for the same computation.
"""

from __future__ import annotations

import asyncio
import json
from typing import Any, Mapping

from fastapi import Request
from fastapi.responses import Response

from kfio import InvalidInput, load_json, parse_number

from .cache import AnswerCache, CachedAnswer, canonical_json
from .jobs import PRELOAD
from .pool import WorkerPool
from .problems import Problem, ProblemError, problem_from_exception
from .settings import Settings


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


def requested_budget(tree: Any) -> float | None:
    """``options.time_budget_s`` if it is a valid number; the worker reports it otherwise."""
    options = tree.get("options") if isinstance(tree, dict) else None
    if not isinstance(options, dict) or "time_budget_s" not in options:
        return None
    try:
        value = parse_number(options["time_budget_s"], "/options/time_budget_s")
    except InvalidInput:
        return None
    return float(value) if value > 0 else None


class Dispatcher:
    """Answers job requests for one app: owns its worker pool and its cache."""

    def __init__(self, settings: Settings) -> None:
        self.settings = settings
        self.pool = WorkerPool(
            settings.workers,
            "kfio.service.jobs:run_job",
            preload=PRELOAD,
            max_waiting=settings.max_queue,
            kill_grace_s=settings.kill_grace_s,
        )
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
        tree = load_json(body)
        key = f"{job} {json.dumps(dict(params), sort_keys=True)} {canonical_json(tree)}"
        hit = self.cache.get(key)
        if hit is not None:
            return Response(hit.content, media_type=hit.media_type, headers={"X-Cache": "hit"})
        task = self._inflight.get(key)
        if task is None:
            budget = min(self.settings.time_budget_s, requested_budget(tree) or self.settings.time_budget_s)
            task = asyncio.get_running_loop().create_task(self._compute(key, job, body, params, budget))
            self._inflight[key] = task
            task.add_done_callback(lambda t: self._forget(key, t))
        # shield: a client that goes away does not cancel work others wait for
        answer = await asyncio.shield(task)
        return Response(answer.content, media_type=answer.media_type, headers={"X-Cache": "miss"})

    def _forget(self, key: str, task: asyncio.Task[CachedAnswer]) -> None:
        self._inflight.pop(key, None)
        if not task.cancelled():
            task.exception()  # retrieved here: every waiter may have gone away

    async def _compute(self, key: str, job: str, body: bytes, params: Mapping[str, Any], budget: float) -> CachedAnswer:
        try:
            outcome = await self.pool.run((job, body, self.settings, dict(params)), budget)
        except Exception as exc:  # noqa: BLE001 - pool failures are problems too
            raise ProblemError(problem_from_exception(exc)) from None
        if outcome[0] != "ok":
            raise ProblemError(Problem.from_dict(outcome[1]))
        answer = CachedAnswer(outcome[1], outcome[2])
        self.cache.put(key, answer)
        return answer
