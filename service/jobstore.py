"""Long work as jobs: a bounded in-memory store with its own lane of worker processes.

A synchronous request has a short budget (``KFIO_TIME_BUDGET_S``, 30 s).  Work
that needs longer is submitted as a *job*: it is queued, run by one of
``job_workers`` worker processes that synchronous requests never use (so they
are not starved), polled, and may be cancelled, which kills the worker running it.

The interface, for kinds beyond ``analyze``/``bounds``/``simulate``
-------------------------------------------------------------------------
A job has a ``kind`` (registered by name), a ``body`` (the raw request bytes),
``params`` (a dict, e.g. query parameters), a ``budget_s``, a ``status``
(``queued``, ``running``, ``done``, ``failed``, ``cancelled``), a
``progress`` (a dict or ``None``) and, once finished, a result
(``content`` bytes and ``media_type``) or a ``problem``
(:class:`kfio.service.problems.Problem`).

A kind is a :class:`JobKind`: a name and ``async def run(ctx) -> (content,
media_type)`` where ``ctx`` is the job's :class:`JobContext`.  The context
gives the job, :meth:`JobContext.run_in_worker` (runs an entry of
:data:`kfio.service.jobs.JOBS` in the job lane, within what is left of the
job's budget, with worker-side progress if asked) and :meth:`JobContext.report`
(progress set by the kind itself, e.g. "12 of 40 grid points").  Any exception
``run`` raises becomes the job's problem through
:func:`kfio.service.problems.problem_from_exception`.  Register with
:meth:`JobStore.register`; :func:`worker_kind` builds the kind that runs one
worker job (the three built in).  Submit with :meth:`JobStore.submit`, read with
:meth:`JobStore.get`, cancel with :meth:`JobStore.cancel`.

Bounds and lifetime
-------------------
At most ``max_jobs`` jobs wait; beyond that :meth:`JobStore.submit` raises a
429 problem.  A finished job is kept ``job_retention_s`` seconds (its
``expires_at``); sooner, at most ``job_retention`` finished jobs are kept, the
oldest forgotten first (then their id answers 404), and their results hold at
most ``job_retention_bytes`` (the first finished forgotten first; the newest
is kept whatever its size).  A worker that crashes fails its job with a
``worker-crashed`` problem; the lane replaces the worker and goes on with the
next job.

Restarts
--------
Every change of a job is written through :mod:`kfio.service.jobdb` before it
is answered (a 202 is sent once its job is on disk); a write that fails (a
full disk) is a 503 ``store-unavailable`` and nothing is queued.  When the
store starts it reads its jobs back: queued ones run, finished ones answer as
before, and one found ``running`` (the server died under it) is queued
again, since every kind is a pure function of its request.  A job that was
running at :data:`MAX_RUNS` deaths of the server fails with
``interrupted-by-restart`` instead, so a request that kills its server is not
run for ever.  A graceful stop (SIGTERM) puts running jobs back in the queue
without counting a run.

Examples
--------
::

    store = JobStore(settings)
    await store.start()
    job = store.submit("analyze", body)
    ...
    store.get(job.id).status          # "queued", "running", "done", ...
    await store.close()
"""

from __future__ import annotations

import asyncio
import json
import logging
import secrets
import shutil
import tempfile
import time
from collections import OrderedDict
from collections.abc import Callable, Coroutine
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, Mapping

from kfio import load_json

from .dispatch import job_pool
from .io import requested_budget
from .jobdb import StoreUnavailable, open_records
from .pool import PoolTimeout
from .problems import Problem, ProblemError, problem_from_exception
from .progress import PROGRESS_KEY, read_progress
from .settings import Settings
from .sweep_jobs import sweep_fraction

log = logging.getLogger("kfio.service")

STATUSES = ("queued", "running", "done", "failed", "cancelled")
FINISHED = frozenset({"done", "failed", "cancelled"})

#: Runs a job may start; one found running after the server died this many times fails ``interrupted-by-restart``.
MAX_RUNS = 2

JobOutput = tuple[bytes, str]


@dataclass(eq=False)
class Job:
    """One job (see the module docstring); times are Unix seconds."""

    id: str
    kind: str
    body: bytes
    params: dict[str, Any]
    budget_s: float
    status: str = "queued"
    created: float = field(default_factory=time.time)
    started: float | None = None
    finished: float | None = None
    progress: dict[str, Any] | None = None
    content: bytes | None = None
    media_type: str | None = None
    problem: Problem | None = None
    progress_file: Path | None = None
    options: Any = field(default=None, repr=False)  # the request's options, for progress estimates
    task: asyncio.Task[JobOutput] | None = field(default=None, repr=False)
    attempts: int = 0  # runs started, across restarts of the server
    retention_s: float | None = None  # how long the result is kept once finished

    def status_dict(self) -> dict[str, Any]:
        """The job's state without its result (see :meth:`JobStore.document`)."""
        doc: dict[str, Any] = {
            "id": self.id,
            "kind": self.kind,
            "status": self.status,
            "budget_s": self.budget_s,
            "created_at": _iso(self.created),
            "started_at": _iso(self.started),
            "finished_at": _iso(self.finished),
            "progress": self.progress,
            "attempts": self.attempts,
            "retention_s": self.retention_s,
            "expires_at": _iso(self.expires),
            "links": {"self": f"/v1/jobs/{self.id}", "result": f"/v1/jobs/{self.id}/result"},
        }
        if self.problem is not None:
            doc["problem"] = self.problem.to_dict()
        return doc

    @property
    def expires(self) -> float | None:
        """When the finished job is forgotten at the latest (Unix seconds; ``None`` until it finishes)."""
        if self.finished is None or self.retention_s is None:
            return None
        return self.finished + self.retention_s

    def record(self) -> dict[str, Any]:
        """The job as a :mod:`kfio.service.jobdb` record."""
        return {
            "id": self.id,
            "kind": self.kind,
            "body": self.body,
            "params": self.params,
            "options": self.options,
            "budget_s": self.budget_s,
            "status": self.status,
            "created": self.created,
            "started": self.started,
            "finished": self.finished,
            "attempts": self.attempts,
            "content": self.content,
            "media_type": self.media_type,
            "problem": None if self.problem is None else self.problem.as_plain(),
        }

    @classmethod
    def from_record(cls, record: Mapping[str, Any]) -> Job:
        """The job a :mod:`kfio.service.jobdb` record holds."""
        problem = record.get("problem")
        return cls(
            id=record["id"],
            kind=record["kind"],
            body=record["body"] or b"",
            params=dict(record["params"] or {}),
            budget_s=record["budget_s"],
            status=record["status"],
            created=record["created"],
            started=record["started"],
            finished=record["finished"],
            content=record["content"],
            media_type=record["media_type"],
            problem=None if problem is None else Problem.from_dict(problem),
            options=record["options"],
            attempts=record["attempts"],
        )


class JobContext:
    """What a :class:`JobKind`'s ``run`` gets: its job, the job lane, a progress setter."""

    def __init__(self, store: JobStore, job: Job, deadline: float) -> None:
        self.store = store
        self.job = job
        self.deadline = deadline

    @property
    def remaining_s(self) -> float:
        """Seconds left of the job's budget."""
        return max(0.0, self.deadline - time.monotonic())

    def report(self, **progress: Any) -> None:
        """Set the job's progress (any JSON-able members, e.g. ``done=3, total=40``)."""
        self.job.progress = dict(progress)

    async def run_in_worker(
        self, worker_job: str, body: bytes, params: Mapping[str, Any] | None = None, track: bool = True
    ) -> JobOutput:
        """Run ``kfio.service.jobs.JOBS[worker_job]`` in the job lane within the remaining budget.

        With ``track`` the worker writes its budget's progress (stage, steps)
        to the job's progress file, which polling reads.

        Raises
        ------
        ProblemError
            The worker job answered a problem, or the lane failed (timeout, crash).
        """
        remaining = self.remaining_s
        if remaining <= 0:
            raise PoolTimeout(f"the job did not finish within {self.job.budget_s:g} s")
        args = dict(params or {})
        if track and self.job.progress_file is not None:
            args[PROGRESS_KEY] = str(self.job.progress_file)
        outcome = await self.store.pool.run((worker_job, body, self.store.settings, args), remaining)
        if outcome[0] != "ok":
            raise ProblemError(Problem.from_dict(outcome[1]))
        return outcome[1], outcome[2]


@dataclass(frozen=True)
class JobKind:
    """A registered kind of job.

    Attributes
    ----------
    name:
        The kind's name (``POST /v1/jobs/<name>`` for the built-in ones).
    run:
        ``async def run(ctx: JobContext) -> (content, media_type)``.
    fraction:
        Optional ``fraction(options, worker_progress) -> float | None``: the
        share of the work done, from the request's ``options`` member (JSON,
        or ``None``) and what the worker's budget last recorded (``stage``,
        ``steps``, ``last_n``).
    """

    name: str
    run: Callable[[JobContext], Coroutine[Any, Any, JobOutput]]
    fraction: Callable[[Any, Mapping[str, Any]], float | None] | None = None


def worker_kind(
    name: str, worker_job: str | None = None, fraction: Callable[[Any, Mapping[str, Any]], float | None] | None = None
) -> JobKind:
    """The kind that runs one worker job (default: the one named ``name``) on the job's body."""
    target = worker_job or name

    async def run(ctx: JobContext) -> JobOutput:
        return await ctx.run_in_worker(target, ctx.job.body, ctx.job.params)

    return JobKind(name, run, fraction)


def simulation_fraction(options: Any, progress: Mapping[str, Any]) -> float | None:
    """Share of the Monte Carlo done: steps ticked over ``trajectories * steps``.

    The simulation ticks its budget once per time step with ``n`` = the number
    of trajectories, so the total is ``n * options.simulate.steps``.
    """
    if progress.get("stage") != "Monte Carlo simulation":
        return None
    from kfio.simulation import SimulationLimits

    sim = options.get("simulate") if isinstance(options, dict) else None
    steps = sim.get("steps") if isinstance(sim, dict) else None
    if not isinstance(steps, int) or steps <= 0:
        steps = SimulationLimits.default_steps
    per_step = progress.get("last_n")
    done = progress.get("steps")
    if not isinstance(per_step, int) or not isinstance(done, int) or per_step <= 0:
        return None
    return min(1.0, done / (per_step * steps))


class JobStore:
    """The jobs of one server, and the worker lane that runs them (see the module docstring)."""

    def __init__(self, settings: Settings) -> None:
        self.settings = settings
        self.pool = job_pool(settings, settings.job_workers, settings.job_workers)
        self.kinds: dict[str, JobKind] = {}
        self._jobs: OrderedDict[str, Job] = OrderedDict()
        self._queue: asyncio.Queue[Job] = asyncio.Queue()
        self._queued = 0
        self._runners: list[asyncio.Task[None]] = []
        self._closing = False
        self.records = open_records(settings.data_dir)  # a directory another server holds fails here
        self._dir = Path(tempfile.mkdtemp(prefix="kfio-jobs-"))
        for kind in BUILTIN_KINDS:
            self.register(kind)

    def register(self, kind: JobKind) -> None:
        """Make ``kind`` available to :meth:`submit` (a later one of the same name wins)."""
        self.kinds[kind.name] = kind

    # -- life cycle -------------------------------------------------------

    async def start(self) -> None:
        """Read back the jobs a previous run kept, start the lane's workers and one runner per worker."""
        self._recover()
        self._runners = [asyncio.create_task(self._runner()) for _ in range(self.settings.job_workers)]
        await self.pool.start()

    def _recover(self) -> None:
        """Jobs of a previous run: queued ones queue again, running ones too (or fail past :data:`MAX_RUNS`)."""
        for record in self.records.load():
            job = Job.from_record(record)
            job.retention_s = self.settings.job_retention_s
            job.progress_file = self._dir / f"{job.id}.progress"
            if job.status == "running":
                if job.attempts >= MAX_RUNS:
                    job.problem = interrupted(job.attempts)
                    self._finish(job, "failed")
                else:
                    job.status, job.started = "queued", None
                    self._write(job, "status", "started")
            if job.kind not in self.kinds and job.status not in FINISHED:
                job.problem = Problem(404, "unknown-job-kind", "Unknown kind of job", f"no job kind {job.kind!r}")
                self._finish(job, "failed")
            self._jobs[job.id] = job
            if job.status == "queued":
                self._queued += 1
                self._queue.put_nowait(job)
        if self._jobs:
            log.info("job store: %d jobs read back, %d queued", len(self._jobs), self._queued)
        self._evict()

    async def close(self) -> None:
        """Stop running jobs, kill the lane, drop the progress files, close the records.

        With durable records, jobs still queued or running stay queued there
        (a running one without counting its run): the next start runs them.
        """
        for runner in self._runners:
            runner.cancel()
        for job in self._jobs.values():
            if job.status == "running":
                job.status, job.started, job.attempts = "queued", None, max(0, job.attempts - 1)
                self._write(job, "status", "started", "attempts")
        self._closing = True  # from here on nothing is written: the records keep these jobs queued
        for job in self._jobs.values():
            if job.status not in FINISHED:
                job.status, job.finished = "cancelled", time.time()
                if job.task is not None:
                    job.task.cancel()
        await asyncio.gather(*self._runners, return_exceptions=True)
        await self.pool.close()
        shutil.rmtree(self._dir, ignore_errors=True)
        self.records.close()

    def stats(self) -> dict[str, int]:
        """Counters for ``/readyz``: jobs by status, and the lane's size."""
        counts = {status: 0 for status in STATUSES}
        for job in self._jobs.values():
            counts[job.status] += 1
        return {"workers": self.settings.job_workers, "max_queued": self.settings.max_jobs, **counts}

    # -- the interface ----------------------------------------------------

    def submit(self, kind: str, body: bytes, params: Mapping[str, Any] | None = None, tree: Any = None) -> Job:
        """Queue a job of ``kind`` on ``body``.

        The body must be JSON (checked here, 422 otherwise) unless the caller
        has read it already and passes its ``tree`` (a sweep may be JSON Lines:
        its caller passes ``{"options": ...}``); the request itself
        is validated by the job, whose problem then says what is wrong.  The
        budget is ``job_time_budget_s``, or less if the request asks for less
        with ``options.time_budget_s``; it counts from when the job starts running.

        Raises
        ------
        ProblemError
            404 for an unknown kind, 429 when ``max_jobs`` jobs are already queued.
        InvalidInput
            The body is not JSON.
        """
        if kind not in self.kinds:
            raise ProblemError(Problem(404, "unknown-job-kind", "Unknown kind of job", f"no job kind {kind!r}"))
        if tree is None:
            tree = load_json(body)
        if self._queued >= self.settings.max_jobs:
            raise ProblemError(
                Problem(
                    429,
                    "too-many-jobs",
                    "Too many jobs queued",
                    f"{self._queued} jobs are already waiting (at most {self.settings.max_jobs}); retry later",
                    retry_after=30,
                )
            )
        limit = self.settings.job_time_budget_s
        budget = min(limit, requested_budget(tree) or limit)
        job = Job(secrets.token_urlsafe(12), kind, body, dict(params or {}), budget)
        job.retention_s = self.settings.job_retention_s
        job.progress_file = self._dir / f"{job.id}.progress"
        if self.kinds[kind].fraction is not None and isinstance(tree, dict):
            job.options = tree.get("options")
        try:
            self.records.add(job.record())  # on disk before anyone is told it was accepted
        except StoreUnavailable as exc:
            log.error("job store: cannot keep a new job: %s", exc)
            raise ProblemError(store_unavailable(str(exc))) from None
        self._jobs[job.id] = job
        self._queued += 1
        self._queue.put_nowait(job)
        self._evict()
        return job

    def get(self, job_id: str) -> Job:
        """The job ``job_id`` with its progress refreshed (404 problem if unknown or forgotten)."""
        self._evict()  # past its expires_at a job is gone even when nothing else finished since
        job = self._jobs.get(job_id)
        if job is None:
            raise ProblemError(
                Problem(
                    404, "unknown-job", "No such job", f"no job {job_id!r} (never accepted, or its retention ended)"
                )
            )
        if job.status == "running" and job.progress_file is not None:
            self._refresh_progress(job)
        return job

    def cancel(self, job_id: str) -> Job:
        """Cancel a queued or running job (its worker is killed and replaced).

        Raises
        ------
        ProblemError
            404 if unknown, 409 if it has already finished.
        """
        job = self.get(job_id)
        if job.status in FINISHED:
            raise ProblemError(
                Problem(409, "job-finished", "Job already finished", f"job {job_id} is already {job.status}")
            )
        if job.status == "queued":
            self._queued -= 1
        self._finish(job, "cancelled")
        if job.task is not None:
            job.task.cancel()  # pool.run kills the worker when its task is cancelled
        return job

    def document(self, job: Job) -> bytes:
        """The JSON of ``GET /v1/jobs/{id}``: the status and, once done, ``result``.

        A JSON result is spliced in as its exact bytes (the report of the
        synchronous endpoint), never re-parsed.
        """
        text = json.dumps(job.status_dict()).encode("utf-8")
        if job.status == "done" and job.content is not None and job.media_type == "application/json":
            return text[:-1] + b', "result": ' + job.content.strip() + b"}"
        return text

    # -- running ----------------------------------------------------------

    async def _runner(self) -> None:
        while True:
            job = await self._queue.get()
            if job.status != "queued":  # cancelled while it waited
                continue
            self._queued -= 1
            job.status, job.started = "running", time.time()
            job.attempts += 1
            self._write(job, "status", "started", "attempts")
            ctx = JobContext(self, job, time.monotonic() + job.budget_s)
            job.task = asyncio.create_task(self.kinds[job.kind].run(ctx))
            await asyncio.wait([job.task])
            self._settle(job, job.task)
            job.task = None
            self._evict()  # a result may have pushed the kept results past their bounds
            if job.progress_file is not None:
                job.progress_file.unlink(missing_ok=True)

    def _settle(self, job: Job, task: asyncio.Task[JobOutput]) -> None:
        if job.status in FINISHED:  # cancelled meanwhile
            return
        if task.cancelled():
            self._finish(job, "cancelled")
            return
        exc = task.exception()
        if exc is None:
            job.content, job.media_type = task.result()
            if job.progress is not None and "fraction" in job.progress:
                job.progress["fraction"] = 1.0
            self._finish(job, "done")
            return
        job.problem = problem_from_exception(exc)
        if job.problem.kind == "internal":
            log.error("job %s (%s) failed", job.id, job.kind, exc_info=exc)
        self._finish(job, "failed")

    def _finish(self, job: Job, status: str) -> None:
        job.status, job.finished = status, time.time()
        job.body = b""  # the request is no longer needed
        self._write(job, "status", "finished", "body", "content", "media_type", "problem")

    def _write(self, job: Job, *members: str) -> None:
        """Write ``members`` of ``job`` through the records (not while closing: the records keep it queued).

        A failed write leaves the record as it was: the job goes on in memory,
        and a restart finds it where the record says (queued or running: it runs again).
        """
        if self._closing:
            return
        record = job.record()
        try:
            self.records.update(job.id, **{member: record[member] for member in members})
        except StoreUnavailable as exc:
            log.error("job store: cannot write job %s (%s): %s", job.id, ", ".join(members), exc)

    def _refresh_progress(self, job: Job) -> None:
        assert job.progress_file is not None
        raw = read_progress(job.progress_file)
        if raw is None:
            return
        progress: dict[str, Any] = {k: raw[k] for k in ("stage", "steps", "elapsed_s") if k in raw}
        kind = self.kinds.get(job.kind)
        if kind is not None and kind.fraction is not None:
            try:
                fraction = kind.fraction(job.options, raw)
            except Exception:  # noqa: BLE001 - an estimate must never fail a poll
                fraction = None
            if fraction is not None:
                progress["fraction"] = round(fraction, 4)
        job.progress = progress

    def _evict(self) -> None:
        """Forget finished jobs past their ``expires_at``; then the first finished first, until at most
        ``job_retention`` are kept and their results hold at most ``job_retention_bytes`` (the newest is
        kept whatever its size)."""
        now = time.time()
        finished = sorted((job for job in self._jobs.values() if job.status in FINISHED), key=_finish_order)
        kept, held = len(finished), sum(_held_bytes(job) for job in finished)
        gone = []
        for job in finished[:-1]:  # job_retention >= 1: the newest is never over the count
            expired = job.expires is not None and job.expires <= now
            if not expired and kept <= self.settings.job_retention and held <= self.settings.job_retention_bytes:
                break
            gone.append(job)
            kept, held = kept - 1, held - _held_bytes(job)
        if finished and finished[-1].expires is not None and finished[-1].expires <= now:
            gone.append(finished[-1])
        for job in gone:
            del self._jobs[job.id]
        if gone and not self._closing:
            try:
                self.records.remove(job.id for job in gone)
            except StoreUnavailable as exc:  # they are forgotten here; the next start forgets them again
                log.error("job store: cannot forget %d finished jobs: %s", len(gone), exc)


def store_unavailable(reason: str) -> Problem:
    """The 503 of a job that could not be written (nothing was queued)."""
    return Problem(
        503,
        "store-unavailable",
        "Job store unavailable",
        f"the job could not be stored ({reason}); nothing was queued; retry later",
        retry_after=30,
    )


def interrupted(runs: int) -> Problem:
    """The problem of a job that was running each of the ``runs`` times its server died."""
    return Problem(
        503,
        "interrupted-by-restart",
        "Job interrupted by restarts",
        f"the server stopped while this job was running, {runs} times; it is not run again",
    )


def _finish_order(job: Job) -> float:
    return job.finished or 0.0


def _held_bytes(job: Job) -> int:
    """What a finished job keeps in memory: its result's bytes (its body was dropped when it finished)."""
    return len(job.content or b"") + len(job.body)


def _iso(t: float | None) -> str | None:
    return None if t is None else datetime.fromtimestamp(t, UTC).isoformat(timespec="seconds")


#: The kinds every store has: the three report endpoints, as jobs.
BUILTIN_KINDS = (
    worker_kind("analyze"),
    worker_kind("bounds"),
    worker_kind("simulate", "simulate-job", fraction=simulation_fraction),
    worker_kind("sweep", fraction=sweep_fraction),
    worker_kind("loop"),
    worker_kind("fit"),
)
