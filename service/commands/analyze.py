"""``kfio analyze FILE [--json] [--ge-grid K] [--ge-plot PNG]``: the exact verdict of Rohr, Marelli and Fu (2014), Theorem 1."""

from __future__ import annotations

import argparse
import dataclasses
from typing import Any

from .. import exitcodes
from ..io import add_request_arguments, dump_json, emit, run_request_command
from .fit import TraceLoader, add_trace_arguments


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "analyze",
        help="exact stability verdict (Rohr, Marelli and Fu (2014), Theorem 1)",
        description="Decide whether the expected error covariance stays bounded. "
        "Exit 0 stable, 1 unstable, 3 boundary, 2 invalid input, 4 budget exceeded, 5 numerical failure.",
    )
    add_request_arguments(p)
    p.add_argument(
        "--ge-grid",
        type=int,
        metavar="K",
        help="Gilbert-Elliott channel: add the exact K x K (p, q) stability map (options.analyze.ge_grid)",
    )
    p.add_argument(
        "--ge-plot",
        metavar="PNG",
        help="Gilbert-Elliott channel: write the exact (q, p) region map as a PNG (grid --ge-grid, default 41)",
    )
    add_trace_arguments(p)
    p.set_defaults(func=_run, quick_exit=True)


def partial_summary(partial: dict[str, Any]) -> str:
    """Text of :attr:`kfio.errors.BudgetExceeded.partial` for the terminal (the bracket on ``sigma_k``)."""
    b = partial.get("sigma_bracket")
    if b is None:
        return "kfio: proved before the budget ran out: " + ", ".join(sorted(partial))
    lo, hi = b["sigma_lower"], b["sigma_upper"]
    return (
        f"Budget exceeded in the search for sigma_k (block |alpha| = {b['modulus']:.6g}, {b['phases']} phases); "
        f"proved so far:\n"
        f"  sigma_k >= {lo['sigma_exact']} = {lo['sigma']:.6g}: {lo['proof']}\n"
        f"  sigma_k <= {hi['sigma_exact']} = {hi['sigma']:.6g}: {hi['proof']}\n"
        f"  {b['implies']}"
    )


def _run(args: argparse.Namespace) -> int:
    from kfio import Budget, BudgetExceeded, Request, analyze  # here, not at import: `kfio --help` stays fast

    traces = TraceLoader(args)

    def work(request: Request, budget: Budget) -> int:
        request = traces.apply(request)
        grid = args.ge_grid if args.ge_grid is not None else (41 if args.ge_plot else None)
        if grid is not None:
            opts = {**request.options.get("analyze", {}), "ge_grid": grid}
            request = dataclasses.replace(request, options={**request.options, "analyze": opts})
        try:
            report = analyze(request, budget=budget)
        except BudgetExceeded as exc:
            if exc.partial is not None:  # what was proved before the budget ran out, then exit code 4
                emit(dump_json(exc.partial) if args.json else partial_summary(exc.partial))
            raise
        if args.ge_plot:
            from ..plots import draw_ge_region

            with open(args.ge_plot, "wb") as fh:
                fh.write(draw_ge_region(report.gilbert_elliott, report.verdict, request))
        if traces.fit is not None:  # the verdict of the whole confidence region beside the point estimate's
            from kfio.fit import analyze_at_confidence

            block = analyze_at_confidence(request, traces.fit, report.verdict, budget)
            out = {**report.to_dict(), "fit": block.to_dict()}
            emit(dump_json(out) if args.json else "\n".join([report.summary(), *block.summary_lines()]))
            return exitcodes.BY_VERDICT[report.verdict]
        emit(dump_json(report.to_dict()) if args.json else report.summary())  # emit: user text made safe
        return exitcodes.BY_VERDICT[report.verdict]

    return run_request_command(args, work, "analyze", loader=traces.load)
