"""``kfio analyze FILE [--json]``: the exact verdict of seed 001, Theorem 1."""

from __future__ import annotations

import argparse

from .. import exitcodes
from ..io import add_request_arguments, dump_json, read_request_text, run_guarded


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "analyze",
        help="exact stability verdict (seed 001, Theorem 1)",
        description="Decide whether the expected error covariance stays bounded. "
        "Exit 0 stable, 1 unstable, 3 boundary, 2 invalid input.",
    )
    add_request_arguments(p)
    p.set_defaults(func=_run, quick_exit=True)


def _run(args: argparse.Namespace) -> int:
    from kfio import analyze, load_request  # here, not at import: `kfio --help` stays fast

    def body() -> int:
        report = analyze(load_request(read_request_text(args.file)))
        print(dump_json(report.to_dict()) if args.json else report.summary())
        return exitcodes.BY_VERDICT[report.verdict]

    return run_guarded(body)
