"""``kfio check [FILE] [--junit XML] [--markdown MD] [--json]``: requirements as code.

FILE (JSON or TOML; default ``kfio-check.json`` or ``kfio-check.toml`` here)
lists plants and channels by file and the requirements each must meet (see
docs/check.md).  Every requirement is judged on the report of ``kfio
analyze``, ``bounds`` or ``simulate``, the runs in parallel.  Prints a table
(or ``--json``); ``--junit`` writes JUnit XML, one test case per requirement;
``--markdown`` writes a summary for a CI step.  Exit 0 every requirement
holds, 1 one fails (or could not be judged), 2 the check file (or a plant or
channel file) is invalid, naming the field, 4 the budget ran out first.

The check file may name only regular files under its own directory (symlinks
followed; ``--allow-outside DIR``, repeatable, allows another directory):
a check file from a pull request must not read the CI runner's files.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from .. import exitcodes
from ..io import add_time_budget_argument, dump_json, emit, memory_limit, run_guarded, time_budget

#: Where ``kfio check`` looks when no FILE is given, in this order.
DEFAULT_FILES = ("kfio-check.json", "kfio-check.toml")


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "check",
        help="judge plants and channels against requirements in a check file (JUnit, Markdown, JSON for CI)",
        description="Requirements as code: a check file lists plants and channels by file and the requirements "
        "on each (verdict, margin on the worst rate, critical arrival probability, trace(V_bar), tail exponent, "
        "outage probability). All are evaluated in parallel; a table goes to stdout. Exit 0 all requirements hold, "
        "1 a requirement fails or could not be judged, 2 invalid check file (the field is named), 4 budget "
        "exceeded. Example: kfio check examples/check/kfio-check.json --junit report.xml",
    )
    p.add_argument(
        "file",
        metavar="FILE",
        nargs="?",
        help=f"check file, JSON or TOML (default: {' or '.join(DEFAULT_FILES)} in the current directory)",
    )
    p.add_argument("--json", action="store_true", help="print the JSON result instead of the table")
    p.add_argument("--junit", metavar="XML", help="write JUnit XML: one test case per requirement")
    p.add_argument("--markdown", metavar="MD", help="write a Markdown summary (for a CI step summary)")
    p.add_argument("--workers", type=int, metavar="N", help="worker processes (default: cores; 1 runs in this process)")
    add_time_budget_argument(
        p,
        "of the whole check; default: options.time_budget_s of the file, else 600; past it the workers are "
        "stopped, exit 4",
    )
    p.add_argument("--memory-mb", type=int, metavar="M", help="address-space limit of each worker in MiB (0: none)")
    p.add_argument(
        "--allow-outside",
        action="append",
        default=[],
        metavar="DIR",
        help="let the check file name files under DIR too (repeatable); by default it may name only regular files "
        "under its own directory, symlinks followed",
    )
    p.set_defaults(func=_run)


def _default_file() -> str:
    from kfio.errors import InvalidInput

    for name in DEFAULT_FILES:
        if Path(name).is_file():
            return name
    raise InvalidInput("FILE", f"no check file given and none of {list(DEFAULT_FILES)} in {os.getcwd()}")


def _allowed_dirs(dirs: list[str]) -> list[str]:
    """The ``--allow-outside`` directories, each an existing directory (these paths are the caller's own)."""
    from kfio.errors import InvalidInput

    for d in dirs:
        if not os.path.isdir(d):
            raise InvalidInput("--allow-outside", f"{d!r} is not a directory")
    return dirs


def _write(path: str, text: str, flag: str) -> None:
    from kfio.errors import InvalidInput

    try:
        Path(path).write_text(text, encoding="utf-8")
    except OSError as exc:
        raise InvalidInput(flag, f"cannot write {path!r}: {exc.strerror}") from None


def _run(args: argparse.Namespace) -> int:
    def body() -> int:
        from kfio.check import load_check, run_check
        from kfio.errors import InvalidInput

        from ..check_report import headline, junit_xml, markdown, table

        if args.workers is not None and args.workers < 1:
            raise InvalidInput("--workers", "must be a positive integer")
        seconds = time_budget(args)
        memory = memory_limit(args)
        spec = load_check(args.file or _default_file(), _allowed_dirs(args.allow_outside))
        result = run_check(spec, workers=args.workers, time_budget_s=seconds, memory_bytes=memory)
        if args.junit:
            _write(args.junit, junit_xml(result), "--junit")
        if args.markdown:
            _write(args.markdown, markdown(result), "--markdown")
        if args.json:
            emit(dump_json(result.to_dict()))
        else:
            emit(table(result))
        if result.status != "pass":
            emit(headline(result), sys.stderr)
        return {"pass": exitcodes.STABLE, "fail": exitcodes.UNSTABLE, "budget": exitcodes.BUDGET}[result.status]

    return run_guarded(body)
