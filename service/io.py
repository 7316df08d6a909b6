"""Input and output helpers shared by the CLI commands."""

from __future__ import annotations

import argparse
import os
import sys
from typing import TYPE_CHECKING, Any, Callable, TextIO

from kfio.errors import BudgetExceeded, InvalidInput, MissingDependency, NumericalFailure
from kfio.model import MAX_RUN_BUDGET_S, MIN_TIME_BUDGET_S, read_limited

if TYPE_CHECKING:  # the analyzer is imported when a command runs, not for `kfio --help`
    from kfio import Budget, Request

from . import exitcodes
from .watchdog import DEFAULT_MEMORY_MB, MAX_MEMORY_MB, memory_message, run_supervised

#: Budget of a command whose request and flags name none (seconds).
DEFAULT_TIME_BUDGET_S = 120.0

MAX_REQUEST_BYTES = 1 << 20


def read_request_text(path: str, max_bytes: int = MAX_REQUEST_BYTES, what: str = "request") -> bytes:
    """Read a request from ``path`` (``-`` for stdin), at most ``max_bytes`` (1 MiB)."""
    return read_limited(path, max_bytes, "/", f"{what} is larger than {max_bytes} bytes")


#: The range of ``--time-budget`` in seconds, the same for every computing command.
TIME_BUDGET_RANGE = (float(MIN_TIME_BUDGET_S), float(MAX_RUN_BUDGET_S))


def add_time_budget_argument(p: argparse.ArgumentParser, what: str) -> None:
    """``--time-budget S`` of every computing command; ``what`` says its default and how it is enforced."""
    lo, hi = TIME_BUDGET_RANGE
    p.add_argument(
        "--time-budget", type=float, metavar="S", help=f"wall-clock budget in seconds, {lo:g}..{hi:g} ({what})"
    )


def time_budget(args: argparse.Namespace) -> float | None:
    """``--time-budget`` of ``args``, checked against :data:`TIME_BUDGET_RANGE` (``None`` when not given)."""
    lo, hi = TIME_BUDGET_RANGE
    if args.time_budget is not None and not lo <= args.time_budget <= hi:
        raise InvalidInput("--time-budget", f"must be in [{lo:g}, {hi:g}] seconds")
    seconds: float | None = args.time_budget
    return seconds


def add_request_arguments(p: argparse.ArgumentParser) -> None:
    """Arguments every request-taking command shares."""
    p.add_argument("file", metavar="FILE", help="request JSON file, or - for standard input")
    p.add_argument("--json", action="store_true", help="print the JSON report instead of a summary")
    add_time_budget_argument(
        p,
        f"default: options.time_budget_s of the request, else {DEFAULT_TIME_BUDGET_S:g}; enforced by a watchdog "
        "that stops the work, exit 4",
    )
    p.add_argument(
        "--memory-mb",
        type=int,
        metavar="M",
        help="address-space limit of the computation in MiB (default: KFIO_MEMORY_MB, else "
        f"{DEFAULT_MEMORY_MB}; 0 for none); past it, exit 4",
    )


def requested_budget(tree: Any) -> float | None:
    """``options.time_budget_s`` if it is a valid number; the worker reports it otherwise."""
    from kfio.model import parse_number

    options = tree.get("options") if isinstance(tree, dict) else None
    if not isinstance(options, dict) or "time_budget_s" not in options:
        return None
    try:
        value = parse_number(options["time_budget_s"], "/options/time_budget_s")
    except InvalidInput:
        return None
    return float(value) if value > 0 else None


def request_budget(data: bytes) -> float | None:
    """``options.time_budget_s`` of a request's bytes, read leniently (the validator reports bad values)."""
    from kfio.model import load_json

    try:
        return requested_budget(load_json(data))
    except InvalidInput:
        return None


def memory_limit(args: argparse.Namespace) -> int | None:
    """The ``--memory-mb`` limit in bytes (``None``: no limit)."""
    rule = f"must be a whole number of MiB in [0, {MAX_MEMORY_MB}] (0: no limit)"
    mb, name = args.memory_mb, "--memory-mb"
    if mb is None:
        name = "KFIO_MEMORY_MB"
        text = os.environ.get(name, "").strip()
        if not text:
            mb = DEFAULT_MEMORY_MB
        elif text.isascii() and text.isdigit() and len(text) <= 12:
            mb = int(text)
        else:
            raise InvalidInput(name, rule)
    if not 0 <= mb <= MAX_MEMORY_MB:
        raise InvalidInput(name, rule)
    return mb << 20 if mb else None


def run_request_command(
    args: argparse.Namespace,
    work: Callable[[Request, Budget], int],
    command: str | None = None,
    loader: Callable[[bytes, Any], Request] | None = None,
) -> int:
    """Read the request of ``args.file`` and run ``work(request, budget)`` under the watchdog.

    The budget is ``--time-budget``, else the request's ``options.time_budget_s``,
    else :data:`DEFAULT_TIME_BUDGET_S`; the work gets it as a cooperative
    :class:`kfio.Budget` and the watchdog (:func:`kfio.service.watchdog.run_supervised`)
    kills it shortly after.  The request is validated with the size limits of
    ``command`` (:meth:`kfio.Limits.for_command`), by ``loader(data, limits)`` when given
    (default :func:`kfio.load_request`).  Exit codes as :func:`run_guarded`.
    """

    def body() -> int:
        flag = time_budget(args)
        memory = memory_limit(args)
        data = read_request_text(args.file)
        seconds = flag or request_budget(data) or DEFAULT_TIME_BUDGET_S

        def child() -> int:
            from kfio import DEFAULT_LIMITS, Budget, load_request

            limits = DEFAULT_LIMITS.for_command(command)
            load = loader or load_request
            return run_guarded(lambda: work(load(data, limits), Budget(seconds=seconds)))

        return run_supervised(child, seconds, memory_bytes=memory)

    return run_guarded(body)


def dump_json(report: dict[str, Any]) -> str:
    """Stable JSON text: fixed key order as built, two-space indent (the text of ``report.to_json()``)."""
    from kfio._reporting import json_text

    return json_text(report)


def emit(text: str, stream: TextIO | None = None) -> None:
    """Print ``text`` so that no user string can make printing fail.

    Sensor names and keys are user text: a control character a terminal would
    act on (ESC, ...) is written as a visible escape (:func:`kfio._reporting.terminal_text`),
    and whatever the terminal's encoding, a character it cannot show is
    written as a backslash escape instead of raising ``UnicodeEncodeError``.
    """
    from kfio._reporting import terminal_text
    from kfio.model import escaped

    stream = stream if stream is not None else sys.stdout
    encoding = getattr(stream, "encoding", None) or "utf-8"
    print(terminal_text(escaped(text)).encode(encoding, "backslashreplace").decode(encoding), file=stream)


def run_guarded(body: Callable[[], int]) -> int:
    """Run a command body, mapping errors to exit codes and one stderr line."""
    try:
        return body()
    except InvalidInput as exc:
        emit(f"kfio: invalid input at {exc.field}: {exc.rule}", sys.stderr)
        return exitcodes.INVALID_INPUT
    except BudgetExceeded as exc:
        emit(f"kfio: budget exceeded: {exc}", sys.stderr)
        return exitcodes.BUDGET
    except MemoryError:
        print(memory_message(), file=sys.stderr)
        return exitcodes.BUDGET
    except NumericalFailure as exc:
        emit(f"kfio: numerical failure: {exc}", sys.stderr)
        return exitcodes.NUMERICAL
    except MissingDependency as exc:
        emit(f"kfio: missing dependency: {exc}", sys.stderr)
        return exitcodes.MISSING_DEPENDENCY
    except KeyboardInterrupt:
        emit("kfio: interrupted", sys.stderr)
        return 130
