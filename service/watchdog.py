"""The CLI's watchdog: a command's work runs in a child process that is killed past its budget.

The library's budgets are cooperative (:class:`kfio.Budget` is checked
between steps), so a long C call (a SymPy/FLINT factorisation, a NumPy
kernel, a solver) can outrun them.  :func:`run_supervised` forks the process
(the imports are done, so this costs milliseconds), runs the work in the
child under an address-space limit (``RLIMIT_AS``), and waits for it at most
``budget_s + grace_s`` seconds; then it kills the child and the command
exits 4 with one line on stderr.  What the child prints is captured and
printed by the parent, so output is never half-written.

Examples
--------
>>> run_supervised(lambda: 3, budget_s=10)
3
"""

from __future__ import annotations

import io
import os
import pickle
import select
import signal
import sys
import time
import traceback
from contextlib import redirect_stderr, redirect_stdout
from typing import Callable

from . import exitcodes

#: Default memory limit (MiB) of one analysis process: a CLI command's child, a service worker
#: (``KFIO_MEMORY_MB``, ``--memory-mb``; the figures behind it are in docs/service.md).
DEFAULT_MEMORY_MB = 3072

#: Largest memory limit accepted (MiB): 16 TiB, above any machine's memory and within ``RLIMIT_AS``'s range.
MAX_MEMORY_MB = 1 << 24

#: Seconds past the budget before the child is killed (it may raise ``BudgetExceeded`` itself first).
DEFAULT_GRACE_S = 2.0

#: Signals by which a child under a memory limit dies when an allocation in C code fails.
_MEMORY_SIGNALS = {signal.SIGABRT, signal.SIGSEGV, signal.SIGBUS, signal.SIGKILL}


#: The limit :func:`limit_memory` set in this process (for messages).
_current_limit: int | None = None


def limit_memory(memory_bytes: int | None) -> None:
    """Cap this process's address space (``RLIMIT_AS``) at ``memory_bytes`` (``None``: no change)."""
    global _current_limit
    if memory_bytes is None:
        return
    _current_limit = memory_bytes
    import resource

    _soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    limit = memory_bytes if hard == resource.RLIM_INFINITY else min(memory_bytes, hard)
    resource.setrlimit(resource.RLIMIT_AS, (limit, hard))


def _child(work: Callable[[], int], memory_bytes: int | None, out_fd: int) -> None:
    out, err = io.StringIO(), io.StringIO()
    code = exitcodes.INTERNAL
    try:
        with redirect_stdout(out), redirect_stderr(err):
            try:
                limit_memory(memory_bytes)
                code = work()
            except MemoryError:
                code = exitcodes.BUDGET
                print(memory_message(memory_bytes), file=sys.stderr)
            except BaseException:  # noqa: BLE001 - reported to the parent as a bug
                traceback.print_exc()
                print("kfio: internal error (this is a bug; please report the request that caused it)", file=sys.stderr)
        payload = pickle.dumps((code, out.getvalue(), err.getvalue()))
        with os.fdopen(out_fd, "wb") as fh:
            fh.write(payload)
    finally:
        os._exit(0)


def memory_message(memory_bytes: int | None = None) -> str:
    """The one stderr line of a command that ran out of memory (default: this process's limit)."""
    memory_bytes = memory_bytes if memory_bytes is not None else _current_limit
    limit = f"the limit of {memory_bytes >> 20} MiB (--memory-mb)" if memory_bytes else "the available memory"
    return f"kfio: memory budget exceeded: the computation needs more than {limit}"


def run_supervised(
    work: Callable[[], int],
    budget_s: float | None,
    grace_s: float = DEFAULT_GRACE_S,
    memory_bytes: int | None = None,
) -> int:
    """Run ``work()`` (returning an exit code) in a forked child with a hard deadline.

    Parameters
    ----------
    work:
        The command's body; what it prints to ``sys.stdout`` / ``sys.stderr``
        is printed by the parent after it finishes.
    budget_s:
        Wall-clock budget in seconds (``None``: no deadline).
    grace_s:
        Time past the budget before the child is killed.
    memory_bytes:
        Address-space limit of the child (``None``: none).

    Returns
    -------
    int
        The child's exit code; :data:`~kfio.service.exitcodes.BUDGET` when it
        was killed at its deadline or ran out of memory.
    """
    for stream in (sys.stdout, sys.stderr):
        stream.flush()
    read_fd, write_fd = os.pipe()
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the child ends in os._exit
        os.close(read_fd)
        _child(work, memory_bytes, write_fd)
    os.close(write_fd)
    deadline = None if budget_s is None else time.monotonic() + budget_s + grace_s
    chunks: list[bytes] = []
    killed = False
    try:
        with os.fdopen(read_fd, "rb", buffering=0) as pipe:
            while True:
                timeout = None if deadline is None else max(0.0, deadline - time.monotonic())
                ready, _, _ = select.select([pipe], [], [], timeout)
                if not ready:
                    os.kill(pid, signal.SIGKILL)
                    killed = True
                    break
                chunk = pipe.read(1 << 16)
                if not chunk:
                    break
                chunks.append(chunk)
    except KeyboardInterrupt:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        print("kfio: interrupted", file=sys.stderr)
        return 130
    _, status = os.waitpid(pid, 0)
    if killed:
        print(
            f"kfio: budget exceeded: the computation did not finish within {budget_s:g} s; it was stopped",
            file=sys.stderr,
        )
        return exitcodes.BUDGET
    if not chunks:
        sig = os.WTERMSIG(status) if os.WIFSIGNALED(status) else None
        if memory_bytes is not None and sig in _MEMORY_SIGNALS:
            print(memory_message(memory_bytes) + f" (the process died of signal {sig})", file=sys.stderr)
            return exitcodes.BUDGET
        print(f"kfio: internal error: the computation process died (status {status})", file=sys.stderr)
        return exitcodes.INTERNAL
    code, out, err = pickle.loads(b"".join(chunks))
    sys.stdout.write(out)
    sys.stderr.write(err)
    return int(code)
