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
import signal
import sys
import time
import traceback
from contextlib import redirect_stderr, redirect_stdout
from typing import Callable

from kfio._workers import ALLOCATION_SIGNALS, Died, memory_limit, run_all

from . import exitcodes

#: Default memory limit (MiB) of one analysis process: a CLI command's child, a service worker
#: (``KFIO_MEMORY_MB``, ``--memory-mb``; the figures behind it are in docs/service.md).
DEFAULT_MEMORY_MB = 3072

#: Largest memory limit accepted (MiB): 16 TiB, above any machine's memory and within ``RLIMIT_AS``'s range.
MAX_MEMORY_MB = 1 << 24

#: Seconds past the budget before the child is killed (it may raise ``BudgetExceeded`` itself first).
DEFAULT_GRACE_S = 2.0

#: Signals by which a child under a memory limit dies when an allocation fails: in C code, or the
#: kernel's OOM killer (SIGKILL: the watchdog's own kill at the deadline is told apart by the clock).
_MEMORY_SIGNALS = ALLOCATION_SIGNALS | {signal.SIGKILL}


def _captured(work: Callable[[], int], memory_bytes: int | None, _budget_s: float | None) -> tuple[int, str, str]:
    """In the child: ``work()``'s exit code and what it printed, never an exception."""
    out, err = io.StringIO(), io.StringIO()
    code = exitcodes.INTERNAL
    with redirect_stdout(out), redirect_stderr(err):
        try:
            code = work()
        except MemoryError:
            code = exitcodes.BUDGET
            print(memory_message(memory_bytes), file=sys.stderr)
        except BaseException:  # noqa: BLE001 - reported to the parent as a bug
            traceback.print_exc()
            print("kfio: internal error (this is a bug; please report the request that caused it)", file=sys.stderr)
    return code, out.getvalue(), err.getvalue()


def memory_message(memory_bytes: int | None = None) -> str:
    """The one stderr line of a command that ran out of memory (default: this process's limit)."""
    memory_bytes = memory_bytes if memory_bytes is not None else memory_limit()
    limit = f"the limit of {memory_bytes >> 20} MiB (--memory-mb)" if memory_bytes else "the available memory"
    return f"kfio: memory budget exceeded: the computation needs more than {limit}"


def run_supervised(
    work: Callable[[], int],
    budget_s: float | None,
    grace_s: float = DEFAULT_GRACE_S,
    memory_bytes: int | None = None,
) -> int:
    """Run ``work()`` (returning an exit code) in a forked child with a hard deadline.

    The child is one worker of :func:`kfio._workers.run_all` (``fork``: ``work``
    may be any function, nothing is pickled), which kills it at the deadline.

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
    deadline = None if budget_s is None else time.monotonic() + budget_s + grace_s

    def child(budget: float | None) -> tuple[int, str, str]:
        return _captured(work, memory_bytes, budget)

    try:
        answers = run_all(child, [((), budget_s)], workers=1, deadline=deadline, memory_bytes=memory_bytes)
    except KeyboardInterrupt:  # run_all has killed the child
        print("kfio: interrupted", file=sys.stderr)
        return 130
    if 0 not in answers:
        print(
            f"kfio: budget exceeded: the computation did not finish within {budget_s:g} s; it was stopped",
            file=sys.stderr,
        )
        return exitcodes.BUDGET
    answer = answers[0]
    if isinstance(answer, Died):
        sig = -answer.exit_code if answer.exit_code is not None and answer.exit_code < 0 else None
        if memory_bytes is not None and sig in _MEMORY_SIGNALS:
            print(memory_message(memory_bytes) + f" (the process died of signal {sig})", file=sys.stderr)
            return exitcodes.BUDGET
        print(f"kfio: internal error: the computation process died (exit code {answer.exit_code})", file=sys.stderr)
        return exitcodes.INTERNAL
    code, out, err = answer
    sys.stdout.write(out)
    sys.stderr.write(err)
    return int(code)
