"""Worker processes: the process mechanics every pool of kfio's builds on.

kfio's budgets are cooperative (:class:`kfio.Budget` is checked between
steps), so a long C call (a SymPy/FLINT factorisation, a NumPy kernel, a
solver) can outrun them, and an allocation in C can grow past any memory.  The
only sure stop is to run the work in a process of its own and kill that
process.  Three pools do so: the service's asynchronous pool
(``kfio.service.pool``), the CLI's watchdog (``kfio.service.watchdog``) and the
runs of a check file (:mod:`kfio.check`); the Dask engine of :mod:`kfio.sweep`
has workers of Dask's own.  This module is what they share:

* :func:`limit_memory`: an address-space limit (``RLIMIT_AS``) for the work;
* :class:`Worker`: a :mod:`multiprocessing` process with a duplex pipe and a
  lifeline (:func:`exit_with_server`), started by :meth:`Worker.start`,
  killed by :meth:`Worker.kill`;
* the message protocol, pickled messages over the pipe (:func:`worker_main`):
  a new worker says :data:`READY` once its imports are done and its memory is
  limited; then, per task, the parent sends ``(args, budget_s)`` and the
  worker answers ``runner(*args, budget_s)``;
* :func:`died_of_allocation`: how a worker that died reads under a memory
  limit;
* :func:`run_all`: a blocking pool over a list of tasks with one deadline for
  all, past which every worker still computing is killed (the watchdog and the
  check use it; the service pool waits for the same pipes on its event loop).

Examples
--------
>>> sorted(run_all(max, [((3, 7), 1.0), ((2, 1), 5.0)], workers=2, deadline=None).items())
[(0, 7), (1, 5.0)]
"""

from __future__ import annotations

import fcntl
import importlib
import multiprocessing
import os
import signal
import time
from collections import deque
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any, Callable, Sequence, TypeGuard, cast

#: The first message of a worker: its imports are done, it reads tasks now.
READY = "ready"

#: Signals of a worker whose C code failed an allocation under its memory limit (FLINT aborts, others crash).
ALLOCATION_SIGNALS = frozenset({signal.SIGABRT, signal.SIGSEGV, signal.SIGBUS})

#: A task's runner: a function, or ``"module:function"`` (what a forkserver or spawned worker imports).
Runner = Callable[..., Any] | str

#: The limit :func:`limit_memory` set in this process (for messages).
_current_limit: int | None = None


def limit_memory(memory_bytes: int | None) -> None:
    """Cap this process's address space (``RLIMIT_AS``) at ``memory_bytes`` (``None`` or ``0``: no change)."""
    global _current_limit
    if not memory_bytes:
        return
    _current_limit = memory_bytes
    import resource

    _soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    limit = memory_bytes if hard == resource.RLIM_INFINITY else min(memory_bytes, hard)
    resource.setrlimit(resource.RLIMIT_AS, (limit, hard))


def memory_limit() -> int | None:
    """The address-space limit :func:`limit_memory` set in this process, if any."""
    return _current_limit


def exit_with_server(lifeline: Connection) -> None:
    """Let the kernel end this worker as soon as its parent is gone, even mid-task.

    ``lifeline`` is the read end of a pipe of this worker alone (``F_SETOWN``
    is per open file description) whose write end only the parent holds and
    nobody writes to, so it hangs up exactly when the parent has exited,
    however it died, or has dropped this worker.  In ``O_ASYNC`` mode the
    hang-up sends SIGIO, whose default action ends the process in the
    kernel: no Python thread has to run, so a task stuck in a long C call
    holding the GIL is ended too.  (Watching the parent process would not do:
    under a forkserver it is the forkserver, which lives as long as any of its
    children.)
    """
    fd = lifeline.fileno()
    signal.signal(signal.SIGIO, signal.SIG_DFL)
    fcntl.fcntl(fd, fcntl.F_SETOWN, os.getpid())
    fcntl.fcntl(fd, fcntl.F_SETFL, fcntl.fcntl(fd, fcntl.F_GETFL) | os.O_ASYNC)
    if lifeline.poll(0):  # the parent died before we were watching
        os._exit(1)


def worker_main(conn: Connection, runner: Runner, lifeline: Connection, memory_bytes: int | None = None) -> None:
    """Body of a worker process: answer tasks until killed or the parent is gone."""
    exit_with_server(lifeline)
    if isinstance(runner, str):
        module, _, name = runner.partition(":")
        runner = cast("Callable[..., Any]", getattr(importlib.import_module(module), name))
    limit_memory(memory_bytes)  # after the imports: the limit is for the work
    conn.send(READY)
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            return
        args, budget_s = msg
        conn.send(runner(*args, budget_s))


@dataclass(eq=False)
class Worker:
    """One worker process, the parent's end of its pipe, and the write end of its lifeline."""

    process: Any  # multiprocessing.Process of the pool's context
    conn: Connection
    keep_alive: Connection
    reserved: bool = False  # a pool's own mark (the service's cheap lane)

    @classmethod
    def start(cls, ctx: Any, runner: Runner, memory_bytes: int | None = None, name: str = "kfio-worker") -> Worker:
        """Start a worker of the :mod:`multiprocessing` context ``ctx`` running ``runner``.

        A function ``runner`` needs the ``fork`` context (nothing is pickled);
        the others import ``"module:function"``.  The worker limits its memory
        to ``memory_bytes`` and says :data:`READY` on its pipe; this call does
        not wait for that.
        """
        parent_end, child_end = ctx.Pipe(duplex=True)
        lifeline, keep_alive = ctx.Pipe(duplex=False)
        proc = ctx.Process(target=worker_main, args=(child_end, runner, lifeline, memory_bytes), daemon=True, name=name)
        proc.start()
        child_end.close()  # so that the worker's death reads as EOF here
        lifeline.close()  # the worker has its own copy; the parent keeps only the write end
        return cls(proc, parent_end, keep_alive)

    def send(self, args: tuple[Any, ...], budget_s: float | None) -> None:
        """Give the worker a task: it answers ``runner(*args, budget_s)`` on its pipe."""
        self.conn.send((args, budget_s))

    def alive(self) -> bool:
        """Whether the process still runs."""
        return bool(self.process.is_alive())

    def exit_code(self, timeout: float = 1.0) -> int | None:
        """The process's exit code once it has ended (``-N``: killed by signal ``N``); ``None`` if it still runs."""
        self.process.join(timeout)
        return cast("int | None", self.process.exitcode)

    def kill(self) -> None:
        """Close the pipes and kill the process (workers hold no state worth a graceful stop)."""
        for end in (self.conn, self.keep_alive):
            try:
                end.close()
            except OSError:  # pragma: no cover - already closed
                pass
        if self.process.is_alive():
            self.process.kill()
        self.process.join(timeout=5)


def died_of_allocation(exit_code: int | None, memory_bytes: int | None) -> TypeGuard[int]:
    """Whether a worker under a memory limit that ended with ``exit_code`` died of a failed C allocation.

    True only for a signal's (negative) exit code, which the caller may then print as ``-exit_code``.
    """
    return bool(memory_bytes) and exit_code is not None and -exit_code in ALLOCATION_SIGNALS


@dataclass(frozen=True)
class Died:
    """The answer :func:`run_all` records for a task whose worker died before answering."""

    exit_code: int | None
    out_of_memory: bool  # :func:`died_of_allocation`


def run_all(
    runner: Runner,
    tasks: Sequence[tuple[tuple[Any, ...], float | None]],
    *,
    workers: int,
    deadline: float | None,
    memory_bytes: int | None = None,
    start_method: str = "fork",
    progress: Callable[[int, int], None] | None = None,
) -> dict[int, Any]:
    """Run every task ``(args, budget_s)`` as ``runner(*args, budget_s)`` in up to ``workers`` processes.

    Tasks start in their order, each on the next free worker.  At ``deadline``
    (:func:`time.monotonic`; ``None`` for none) every worker is killed, computing
    or not, and so is every worker when this call ends, by an exception too
    (``KeyboardInterrupt``).  A worker that dies during a task is replaced.

    Returns
    -------
    dict
        The answer of each finished task by its index; :class:`Died` for a task
        whose worker died; no entry for a task the deadline stopped or never
        started.

    Raises
    ------
    RuntimeError
        A new worker died before it was ready (it could not import ``runner``).
    """
    ctx = multiprocessing.get_context(start_method)
    queue = deque(range(len(tasks)))
    results: dict[int, Any] = {}
    task_of: dict[Connection, tuple[Worker, int | None]] = {}  # by pipe: the worker and its task (None: idle)

    def start() -> None:
        worker = Worker.start(ctx, runner, memory_bytes)
        task_of[worker.conn] = (worker, None)

    def finish(index: int, value: Any) -> None:
        results[index] = value
        if progress is not None:
            progress(len(results), len(tasks))

    try:
        for _ in range(min(workers, len(tasks))):
            start()
        while task_of:
            timeout = None if deadline is None else deadline - time.monotonic()
            if timeout is not None and timeout <= 0:
                break
            for conn in wait(list(task_of), timeout):
                worker, index = task_of.pop(cast(Connection, conn))
                try:
                    value = worker.conn.recv()
                except (EOFError, OSError):
                    code = worker.exit_code()
                    worker.kill()
                    if index is None:
                        raise RuntimeError(f"a new worker died before it was ready (exit code {code})") from None
                    finish(index, Died(code, died_of_allocation(code, memory_bytes)))
                    if queue:
                        start()
                    continue
                if index is not None:
                    finish(index, value)
                if not queue:
                    worker.kill()
                    continue
                index = queue.popleft()
                try:
                    worker.send(*tasks[index])
                except OSError:  # it died since it answered: the task waits for its replacement
                    queue.appendleft(index)
                    worker.kill()
                    start()
                    continue
                task_of[worker.conn] = (worker, index)
    finally:
        for worker, _ in task_of.values():
            worker.kill()
    return results


__all__ = [
    "ALLOCATION_SIGNALS",
    "READY",
    "Died",
    "Runner",
    "Worker",
    "died_of_allocation",
    "exit_with_server",
    "limit_memory",
    "memory_limit",
    "run_all",
    "worker_main",
]
