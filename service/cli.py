"""The ``kfio`` command line: ``kfio analyze FILE [--json]`` and friends.

Sub-commands live in :mod:`kfio.service.commands`, one module each, discovered at
start-up.  Exit codes are listed in :mod:`kfio.service.exitcodes`.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
import traceback
from typing import Sequence

from . import commands, exitcodes


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="kfio",
        description="Stability analyzer for Kalman filters with lossy measurement channels.",
        epilog="Exit codes: 0 stable/ok, 1 unstable, 2 invalid input, 3 boundary, 4 budget exceeded, "
        "5 numerical failure, 6 cannot serve (kfio serve), 70 internal error.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda m: m.name):
        module = importlib.import_module(f"{commands.__name__}.{info.name}")
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: --help exits 0, usage errors are invalid input
        return 0 if exc.code == 0 else exitcodes.INVALID_INPUT
    try:
        return int(args.func(args))
    except Exception:  # noqa: BLE001 - last resort: a bug, reported as such
        traceback.print_exc()
        print("kfio: internal error (this is a bug; please report the request that caused it)", file=sys.stderr)
        return exitcodes.INTERNAL


def entrypoint() -> None:  # console script
    sys.exit(main())


if __name__ == "__main__":
    entrypoint()
