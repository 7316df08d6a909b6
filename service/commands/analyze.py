"""``kfio analyze FILE [--json]``: the exact verdict of seed 001, Theorem 1."""

from __future__ import annotations

import argparse

from kfio import Budget, Request, analyze

from .. import exitcodes
from ..io import add_request_arguments, dump_json, run_request_command


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "analyze",
        help="exact stability verdict (seed 001, Theorem 1)",
        description="Decide whether the expected error covariance stays bounded. "
        "Exit 0 stable, 1 unstable, 3 boundary, 2 invalid input, 4 budget exceeded, 5 numerical failure.",
    )
    add_request_arguments(p)
    p.set_defaults(func=_run)


def _run(args: argparse.Namespace) -> int:
    def work(request: Request, budget: Budget) -> int:
        report = analyze(request, budget=budget)
        print(dump_json(report.to_dict()) if args.json else report.summary())
        return exitcodes.BY_VERDICT[report.verdict]

    return run_request_command(args, work)
