"""A bounded pool of worker processes with a hard deadline per task.

Why not :class:`concurrent.futures.ProcessPoolExecutor`: it cannot stop one
stuck task.  Here every worker is a :class:`multiprocessing.Process` with its
own pipe, so a task past its deadline is ended by killing exactly its worker,
and a fresh worker takes the slot.  The event loop never computes and never
blocks on a worker: it waits for the pipe with ``loop.add_reader``, so
``/healthz`` stays fast while every worker is busy.

Workers are forked from a *forkserver* that has imported :mod:`kfio.service.jobs`
(and with it :mod:`kfio`, NumPy and SymPy) once, so a replacement worker
is ready in milliseconds, and no worker inherits the server's threads.

A pool may hold *reserved* workers beside its ``size`` ones (the cheap lane,
:mod:`kfio.service.lanes`): a task marked ``cheap`` takes a free regular
worker when one is free and nobody waits for one, else a reserved worker; a
cheap task that outlasts ``reserved_budget_s`` there is stopped and runs again
on a regular worker with what is left of its budget.  Other tasks never use
reserved workers, so a few long tasks cannot hold every process.

The process mechanics (a worker with its pipe and lifeline, its memory limit,
the message protocol, killing it) are :mod:`kfio._workers`, which the CLI's
watchdog and ``kfio check`` use too; this module adds what a server needs on
top: waiting for the pipes on the event loop, deadlines per task, the queues,
the reserved workers and the drain.  A new worker says
:data:`~kfio._workers.READY` once its imports are done, and only then joins
the idle queue (a worker still importing does not read, and a large request
written to it would block the event loop).
"""

from __future__ import annotations

import asyncio
import logging
import multiprocessing
import os
import time
from concurrent.futures import ThreadPoolExecutor
from multiprocessing.connection import Connection
from typing import Any, Callable, TypeVar, cast

from kfio._workers import READY, Worker, died_of_allocation

from .threads import one_thread_per_process

log = logging.getLogger("kfio.service")

T = TypeVar("T")

#: Threads of a pool's own for starting, killing and reaping its workers.
_POOL_THREADS = 2


class PoolError(RuntimeError):
    """Base of the pool's own failures (mapped to 503/504 by :mod:`kfio.service.problems`)."""


class PoolBusy(PoolError):
    """No worker became free in time, or too many requests are already waiting."""


class PoolTimeout(PoolError, TimeoutError):
    """The task ran past its deadline; its worker was killed and replaced."""


class WorkerCrashed(PoolError):
    """The worker died while running the task (it was replaced)."""


class WorkerOutOfMemory(WorkerCrashed):
    """The worker died of SIGABRT/SIGSEGV/SIGBUS under a memory limit: C code failed to allocate."""


class _LaneOverrun(PoolError):
    """A cheap task outlasted the reserved workers' budget (it runs again on a regular worker)."""


class PoolShuttingDown(PoolBusy):
    """The server is shutting down: the task was refused, or stopped when the grace period ended."""


class WorkerPool:
    """``size`` worker processes running ``runner`` with per-task deadlines.

    Parameters
    ----------
    size:
        Number of worker processes.
    runner:
        ``"module:function"`` called in the worker as ``function(*args, budget_s)``;
        it should catch its own exceptions and return a picklable value.
    preload:
        Modules the forkserver imports once, before forking workers.
    max_waiting:
        Tasks allowed to wait for a free worker; more are refused with
        :class:`PoolBusy` at once.
    kill_grace_s:
        Time past ``budget_s`` before the worker is killed (lets a cooperative
        budget check raise first).
    start_method:
        :mod:`multiprocessing` start method (``"forkserver"``: workers inherit
        no threads of the server).
    start_timeout_s:
        How long a new worker may take to import its modules and say ready.
    memory_bytes:
        Address-space limit (``RLIMIT_AS``) of each worker once its imports
        are done, or ``None`` for none.
    retire:
        Predicate on a task's result: when true the worker is replaced after
        answering (e.g. it ran out of memory and its heap may be fragmented).
    reserved:
        Worker processes beside ``size`` that only tasks run with ``cheap=True`` use.
    reserved_budget_s:
        Longest a cheap task may run on a reserved worker before it is moved to a regular one.

    Examples
    --------
    ::

        pool = WorkerPool(2, "kfio.service.jobs:run_job")
        await pool.start()
        value = await pool.run(("analyze", body, settings), budget_s=30)
        await pool.close()
    """

    def __init__(
        self,
        size: int,
        runner: str,
        preload: tuple[str, ...] = (),
        max_waiting: int = 64,
        kill_grace_s: float = 0.25,
        start_method: str = "forkserver",
        start_timeout_s: float = 60.0,
        memory_bytes: int | None = None,
        retire: Callable[[Any], bool] | None = None,
        reserved: int = 0,
        reserved_budget_s: float = 2.0,
    ) -> None:
        self.size = size
        self.reserved = reserved
        self.reserved_budget_s = reserved_budget_s
        self.moved = 0  # cheap tasks moved from a reserved worker to a regular one
        self.runner = runner
        self.max_waiting = max_waiting
        self.kill_grace_s = kill_grace_s
        self.start_timeout_s = start_timeout_s
        self.memory_bytes = memory_bytes
        self.retire = retire
        # typeshed's BaseContext has no Process; every concrete start method's context does
        self._ctx = cast(
            "multiprocessing.context.ForkContext | multiprocessing.context.SpawnContext"
            " | multiprocessing.context.ForkServerContext",
            multiprocessing.get_context(start_method),
        )
        if start_method == "forkserver" and preload:
            self._ctx.set_forkserver_preload(list(preload))
        self._idle: asyncio.Queue[Worker] | None = None
        self._spare: asyncio.Queue[Worker] = asyncio.Queue()  # idle reserved workers
        self._spare_waiting = 0
        self._all: set[Worker] = set()
        self._waiting = 0
        self._busy = 0
        self._closed = False
        self._ready = asyncio.Event()
        self._start_error: BaseException | None = None
        self.replaced = 0
        self.completed = 0
        self._draining = False
        self._queued: set[asyncio.Task[Any]] = set()  # tasks waiting for a worker
        self._running: set[asyncio.Task[Any]] = set()  # tasks whose worker computes
        # Spawning, killing and reaping workers run in threads of the pool's own: never in the
        # loop's default executor, which request handlers may fill (a full one once held a
        # replacement back: "replaced: 1" and "alive: 1" for as long as it stayed full).
        self._threads = ThreadPoolExecutor(_POOL_THREADS, thread_name_prefix="kfio-pool")

    async def _in_thread(self, fn: Callable[..., T], *args: Any) -> T:
        """``fn(*args)`` in one of the pool's own threads (inline once the pool is closed)."""
        try:
            return await asyncio.get_running_loop().run_in_executor(self._threads, fn, *args)
        except RuntimeError:  # the executor was shut down by close(): finish the kill here
            return fn(*args)

    # -- life cycle -------------------------------------------------------

    def _spawn(self) -> Worker:
        return Worker.start(self._ctx, self.runner, self.memory_bytes)

    async def _new_worker(self) -> Worker:
        """A started worker that has said :data:`~kfio._workers.READY` (its imports are done)."""
        worker = await self._in_thread(self._spawn)
        try:
            await _readable(worker.conn, self.start_timeout_s)
            hello = worker.conn.recv()
        except (TimeoutError, EOFError, OSError):
            await self._in_thread(worker.kill)
            raise WorkerCrashed(f"a new worker did not become ready (exit code {worker.process.exitcode})") from None
        if hello != READY:  # pragma: no cover - protocol error
            await self._in_thread(worker.kill)
            raise WorkerCrashed(f"a new worker said {hello!r} instead of 'ready'")
        return worker

    async def start(self) -> None:
        """Start every worker (in a thread: the first fork starts the forkserver).

        Tasks submitted meanwhile wait (within their budget) for the pool to be
        up; if starting fails they are refused with :class:`PoolBusy` at once.
        """
        self._idle = asyncio.Queue()
        one_thread_per_process()  # workers processes use workers cores (set before the forkserver starts)
        try:
            workers = await asyncio.gather(*(self._new_worker() for _ in range(self.size + self.reserved)))
            for index, worker in enumerate(workers):
                if self._closed:
                    await self._in_thread(worker.kill)
                    continue
                worker.reserved = index >= self.size
                self._all.add(worker)
                self._release(worker)
        except Exception as exc:
            log.error("the worker pool could not start", exc_info=exc)
            self._start_error = exc
            raise
        finally:
            self._ready.set()

    async def drain(self, grace_s: float) -> None:
        """Stop taking tasks, then give the running ones ``grace_s`` seconds to finish.

        Tasks waiting for a worker, and every task submitted from now on, fail
        at once with :class:`PoolShuttingDown`; tasks still running when the
        grace period ends fail with it too (their workers are killed).  Call
        it when the server is told to stop, before :meth:`close`.
        """
        self._draining = True
        for task in list(self._queued):
            task.cancel(msg=_DRAIN)
        loop = asyncio.get_running_loop()
        end = loop.time() + grace_s
        while self._running and loop.time() < end:
            await asyncio.sleep(0.05)
        for task in list(self._running):
            task.cancel(msg=_DRAIN)

    @property
    def draining(self) -> bool:
        """True once :meth:`drain` was called."""
        return self._draining

    async def close(self) -> None:
        """Kill every worker (they hold no state worth a graceful stop)."""
        self._closed = True
        workers, self._all = list(self._all), set()
        await self._in_thread(_kill_all, workers)
        self._threads.shutdown(wait=False)

    @property
    def ready(self) -> bool:
        """True once all workers were started and at least one is alive."""
        return (
            self._ready.is_set()
            and self._start_error is None
            and not self._closed
            and any(w.process.is_alive() for w in self._all)
        )

    def stats(self) -> dict[str, int]:
        """Counters for ``/readyz``."""
        return {
            "size": self.size,
            "alive": sum(1 for w in self._all if not w.reserved and w.process.is_alive()),
            "busy": self._busy,
            "waiting": self._waiting + self._spare_waiting,
            "completed": self.completed,
            "replaced": self.replaced,
            "reserved": self.reserved,
            "reserved_alive": sum(1 for w in self._all if w.reserved and w.process.is_alive()),
            "moved": self.moved,
        }

    def _release(self, worker: Worker) -> None:
        """Put an idle worker back in its queue (the reserved ones in their own)."""
        if worker.reserved:
            self._spare.put_nowait(worker)
        else:
            assert self._idle is not None
            self._idle.put_nowait(worker)

    async def _replace(self, worker: Worker) -> None:
        self._all.discard(worker)
        self.replaced += 1
        await self._in_thread(worker.kill)
        if self._closed:
            return
        fresh = await self._new_worker()
        if self._closed:
            await self._in_thread(fresh.kill)
            return
        fresh.reserved = worker.reserved
        self._all.add(fresh)
        self._release(fresh)

    def _replace_soon(self, worker: Worker) -> None:
        task = asyncio.get_running_loop().create_task(self._replace(worker))
        task.add_done_callback(_log_task_error)

    # -- running tasks ----------------------------------------------------

    async def _checkout(self, deadline: float, cheap: bool = False) -> Worker:
        if self._draining:
            raise PoolShuttingDown("the server is shutting down and takes no new work")
        task = asyncio.current_task()
        assert task is not None
        self._queued.add(task)
        try:
            if cheap:
                spare = await self._wait_for_spare(deadline)
                if spare is not None:
                    return spare
            return await self._wait_for_worker(deadline)
        except asyncio.CancelledError:
            if not self._draining:
                raise
            task.uncancel()
            raise PoolShuttingDown("the server is shutting down; the request was refused before it ran") from None
        finally:
            self._queued.discard(task)

    def _free_regular(self) -> Worker | None:
        """A free regular worker that nobody is waiting for, if there is one."""
        while self._idle is not None and self._waiting == 0 and not self._idle.empty():
            worker = self._idle.get_nowait()
            if worker.process.is_alive():
                return worker
            self._replace_soon(worker)  # died while idle (e.g. OOM killer)
        return None

    async def _wait_for_spare(self, deadline: float) -> Worker | None:
        """For a cheap task: a free regular worker, else a reserved one (waited for within ``deadline``).

        ``None`` sends the task to the regular queue: the pool has no reserved
        workers, or too many cheap tasks wait already.
        """
        if not self._ready.is_set():
            return None  # _wait_for_worker waits for the start and says why it failed
        regular = self._free_regular()
        if regular is not None or not self.reserved or self._closed:
            return regular
        if self._spare.empty() and self._spare_waiting >= self.max_waiting:
            return None
        self._spare_waiting += 1
        try:
            return await self._next_alive(self._spare, deadline)
        finally:
            self._spare_waiting -= 1

    async def _wait_for_worker(self, deadline: float) -> Worker:
        if not self._ready.is_set():
            try:
                await asyncio.wait_for(self._ready.wait(), max(0.0, deadline - time.monotonic()))
            except TimeoutError:
                raise PoolBusy("the worker pool did not start within the time budget") from None
        if self._idle is None or self._closed or self._start_error is not None:
            raise PoolBusy("the worker pool is not running")
        if self._idle.empty() and self._waiting >= self.max_waiting:
            raise PoolBusy(f"{self._waiting} requests are already waiting for a worker")
        worker = self._free_regular()  # a free worker, nobody before us: no timer, no task
        if worker is not None:
            return worker
        self._waiting += 1
        try:
            return await self._next_alive(self._idle, deadline)
        finally:
            self._waiting -= 1

    async def _next_alive(self, queue: asyncio.Queue[Worker], deadline: float) -> Worker:
        """The next live worker put on ``queue`` before ``deadline``; a dead one (e.g. the OOM killer's) is replaced."""
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise PoolBusy("no worker became free within the time budget")
            try:
                worker = await asyncio.wait_for(queue.get(), remaining)
            except TimeoutError:
                raise PoolBusy("no worker became free within the time budget") from None
            if worker.process.is_alive():
                return worker
            self._replace_soon(worker)

    async def run(self, args: tuple[Any, ...], budget_s: float, cheap: bool = False) -> Any:
        """Run ``runner(*args, remaining_budget)`` in a worker.

        The budget covers waiting for a worker *and* running: the worker is
        told what is left when it starts, and is killed ``kill_grace_s``
        after that.  A ``cheap`` task may run on a reserved worker (see the
        module docstring).

        Raises
        ------
        PoolBusy
            No worker became free within the budget, or the waiting queue is full.
        PoolTimeout
            The task outlived its budget; its worker was killed and replaced.
        WorkerCrashed
            The worker died during the task; it was replaced.
        """
        deadline = time.monotonic() + budget_s
        if cheap and self.reserved:
            try:
                return await self._run_once(args, budget_s, deadline, cheap=True)
            except _LaneOverrun:
                self.moved += 1  # its reserved worker was killed; a regular one takes the task
        return await self._run_once(args, budget_s, deadline)

    async def _run_once(self, args: tuple[Any, ...], budget_s: float, deadline: float, cheap: bool = False) -> Any:
        worker = await self._checkout(deadline, cheap)
        # on a reserved worker the task may run reserved_budget_s, then it moves to a regular one
        limit = min(deadline, time.monotonic() + self.reserved_budget_s) if worker.reserved else deadline
        self._busy += 1
        ok = False
        task = asyncio.current_task()
        assert task is not None
        self._running.add(task)
        try:
            remaining = max(0.0, deadline - time.monotonic())
            try:
                worker.send(args, remaining)
            except (OSError, EOFError, ValueError):
                raise WorkerCrashed("the worker died before it could take the task") from None
            try:
                if limit < deadline:
                    await _readable(worker.conn, max(0.0, limit - time.monotonic()))
                else:
                    await _readable(worker.conn, remaining + self.kill_grace_s)
            except TimeoutError:
                if limit < deadline:
                    raise _LaneOverrun("the task outlasted the reserved workers' budget") from None
                raise PoolTimeout(f"the computation did not finish within {budget_s:g} s; it was stopped") from None
            except asyncio.CancelledError:
                if not self._draining:
                    raise
                task.uncancel()
                raise PoolShuttingDown(
                    "the server is shutting down; the computation was stopped at the end of the grace period"
                ) from None
            try:
                value = worker.conn.recv()
            except (EOFError, OSError):
                code = await self._in_thread(worker.exit_code, 1.0)  # reap it, for the exit code
                if self.memory_bytes is not None and died_of_allocation(code, self.memory_bytes):
                    raise WorkerOutOfMemory(
                        f"the worker process died of signal {-code} during the task, most likely when an "
                        f"allocation in C code went past its memory limit of {self.memory_bytes >> 20} MiB"
                    ) from None
                raise WorkerCrashed(f"the worker process died during the task (exit code {code})") from None
            ok = self.retire is None or not self.retire(value)
            self.completed += 1
            return value
        finally:
            self._busy -= 1
            self._running.discard(task)
            if ok:
                self._release(worker)
            else:  # timed out, crashed, or the request was cancelled mid-task
                self._replace_soon(worker)


_DRAIN = "kfio: the pool is draining"


async def _readable(conn: Connection, timeout: float) -> None:
    """Wait until ``conn`` has data (or EOF) without blocking the event loop."""
    if conn.poll(0):
        return
    loop = asyncio.get_running_loop()
    fut: asyncio.Future[None] = loop.create_future()
    fd = conn.fileno()

    def on_readable() -> None:
        if not fut.done():
            fut.set_result(None)

    loop.add_reader(fd, on_readable)
    try:
        await asyncio.wait_for(fut, timeout)
    finally:
        loop.remove_reader(fd)
        if not os.get_blocking(fd):  # some event loops (uvloop) leave the fd non-blocking: recv() needs it blocking
            os.set_blocking(fd, True)


def _kill_all(workers: list[Worker]) -> None:
    for worker in workers:
        worker.kill()


def _log_task_error(task: asyncio.Task[None]) -> None:
    if not task.cancelled() and task.exception() is not None:
        log.error("replacing a worker failed", exc_info=task.exception())
