"""``kfio bounds FILE [--json] [--grid K] [--horizon N] [--tolerance T] [--sdp-cross-check WHEN]``: the bounds of docs/theory.md

Takes the same request JSON as ``kfio analyze``.  Flags override
``options.bounds`` of the request.  Exit 0 on success, 2 on invalid input
(one stderr line naming the field), 4 when the time budget is exceeded.
"""

from __future__ import annotations

import argparse

from .. import exitcodes
from ..io import add_request_arguments, dump_json, emit, run_request_command


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "bounds",
        help="bounds on the critical arrival probability and the expected error covariance (Sinopoli et al. 2004; Liu and Goldsmith 2004; Rohr, Marelli and Fu 2010)",
        description="Lower and upper bounds on the critical arrival probability (closed form and LMI, "
        "certificates re-checked), S_bar <= lim E[P] <= V_bar at the operating point, Rohr, Marelli and Fu (2010)'s P_hat_N, "
        "and for two sensors a region map. Exit 0 on success, 2 invalid input, 4 budget exceeded.",
    )
    add_request_arguments(p)
    p.add_argument("--grid", type=int, metavar="K", help="K x K region map of two sensors' probabilities (2..41)")
    p.add_argument("--horizon", type=int, metavar="N", help="largest N of P_hat_N (one packet; default 8)")
    p.add_argument("--tolerance", type=float, metavar="T", help="bisection tolerance of lambda_upper (default 1e-6)")
    p.add_argument(
        "--sdp-cross-check",
        dest="sdp_cross_check",
        metavar="WHEN",
        help="solve the V_bar SDP cross-check: auto (default: up to 12 states), always or never",
    )
    p.set_defaults(func=_run, quick_exit=True)


def _run(args: argparse.Namespace) -> int:
    from kfio import Budget, Request  # here, not at import: CVXPY takes seconds to load
    from kfio.riccati_bounds import compute_bounds

    def work(request: Request, budget: Budget) -> int:
        flags = {
            k: getattr(args, k)
            for k in ("grid", "horizon", "tolerance", "sdp_cross_check")
            if getattr(args, k) is not None
        }
        report = compute_bounds(request, flags=flags, budget=budget)
        emit(dump_json(report.to_dict()) if args.json else report.summary())  # emit: user text made safe
        return exitcodes.STABLE

    return run_request_command(args, work)
