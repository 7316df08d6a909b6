"""The ``kfio`` command line: ``kfio analyze FILE [--json]`` and friends.

Sub-commands live in :mod:`kfio.service.commands`, one module each, discovered at
start-up.  Exit codes are listed in :mod:`kfio.service.exitcodes`.  A command
module imports the analyzer only when its command runs, so ``kfio --help`` and
``kfio --version`` load neither SymPy nor CVXPY.
"""

from __future__ import annotations

import argparse
import importlib
import os
import pkgutil
import sys
import traceback
from typing import Sequence

from .._version import __version__
from . import commands, exitcodes
from .threads import one_thread_per_process


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="kfio",
        description="Stability analyzer for Kalman filters with lossy measurement channels.",
        epilog="Exit codes: 0 stable/ok, 1 unstable, 2 invalid input, 3 boundary, 4 budget exceeded, "
        "5 numerical failure, 6 cannot serve (kfio serve), 8 some sweep points failed (kfio sweep), "
        "9 a package the feature needs is not installed, 70 internal error, 141 output pipe closed by its reader.",
    )
    parser.add_argument("--version", action="version", version=f"kfio {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda m: m.name):
        module = importlib.import_module(f"{commands.__name__}.{info.name}")
        module.register(sub)
    return parser


def run(argv: Sequence[str] | None = None) -> tuple[int, argparse.Namespace | None]:
    """The exit code of ``kfio argv``, and the parsed arguments (``None`` if parsing stopped)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: --help exits 0, usage errors are invalid input
        return (0 if exc.code == 0 else exitcodes.INVALID_INPUT), None
    try:
        return int(args.func(args)), args
    except BrokenPipeError:  # the reader went away (`kfio analyze ... | head -1`): not a bug
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # so the final flush is quiet
        return exitcodes.BROKEN_PIPE, args
    except Exception:  # noqa: BLE001 - last resort: a bug, reported as such
        traceback.print_exc()
        print("kfio: internal error (this is a bug; please report the request that caused it)", file=sys.stderr)
        return exitcodes.INTERNAL, args


def main(argv: Sequence[str] | None = None) -> int:
    """The exit code of ``kfio argv`` (for tests and embedding: never exits the process)."""
    return run(argv)[0]


def entrypoint() -> None:  # console script
    one_thread_per_process()  # before anything imports NumPy (kfio.service.threads says why)
    code, args = run()
    if args is not None and getattr(args, "quick_exit", False):
        # A one-shot command has printed its answer and started no process or thread:
        # skip tearing down SymPy's and NumPy's module graphs (about 0.15 s of CPU).
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        except OSError:  # a closed pipe: nothing more can be said
            pass
        os._exit(code)
    sys.exit(code)


if __name__ == "__main__":
    entrypoint()
