"""Input and output helpers shared by the CLI commands."""

from __future__ import annotations

import argparse
import sys
from typing import Any, Callable, TextIO

from kfio._reporting import json_text
from kfio.errors import BudgetExceeded, InvalidInput, NumericalFailure
from kfio.model._exact import escaped

from . import exitcodes

MAX_REQUEST_BYTES = 1 << 20


def read_request_text(path: str) -> bytes:
    """Read a request from ``path`` (``-`` for stdin), at most 1 MiB."""
    try:
        if path == "-":
            data = sys.stdin.buffer.read(MAX_REQUEST_BYTES + 1)
        else:
            with open(path, "rb") as fh:
                data = fh.read(MAX_REQUEST_BYTES + 1)
    except OSError as exc:
        raise InvalidInput("/", f"cannot read {path!r}: {exc.strerror}") from None
    if len(data) > MAX_REQUEST_BYTES:
        raise InvalidInput("/", f"request is larger than {MAX_REQUEST_BYTES} bytes")
    return data


def add_request_arguments(p: argparse.ArgumentParser) -> None:
    """Arguments every request-taking command shares."""
    p.add_argument("file", metavar="FILE", help="request JSON file, or - for standard input")
    p.add_argument("--json", action="store_true", help="print the JSON report instead of a summary")


def dump_json(report: dict[str, Any]) -> str:
    """Stable JSON text: fixed key order as built, two-space indent (the text of ``report.to_json()``)."""
    return json_text(report)


def emit(text: str, stream: TextIO | None = None) -> None:
    """Print ``text`` so that no user string can make printing fail.

    Sensor names and keys are user text; whatever the terminal's encoding,
    a character it cannot show is written as a backslash escape instead of
    raising ``UnicodeEncodeError``.
    """
    stream = stream if stream is not None else sys.stdout
    encoding = getattr(stream, "encoding", None) or "utf-8"
    print(escaped(text).encode(encoding, "backslashreplace").decode(encoding), file=stream)


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
    except NumericalFailure as exc:
        emit(f"kfio: numerical failure: {exc}", sys.stderr)
        return exitcodes.NUMERICAL
    except KeyboardInterrupt:
        emit("kfio: interrupted", sys.stderr)
        return 130
