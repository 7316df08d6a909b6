"""``kfio simulate FILE [--steps T] [--trajectories M] [--seed S] [--json] [--exact]``.

Monte Carlo of the stochastic Riccati recursion (Rohr, Marelli and Fu (2014), eq. (2)) and,
with ``--exact``, the exact ``E[P_t]`` of Rohr, Marelli and Fu (2014), eq. (7) for small ``t``.
Flags override ``options.simulate`` of the request; an invalid value is
reported at its JSON pointer there (``/options/simulate/steps`` for
``--steps``).  Exit 0 ok, 2 invalid input, 4 budget exceeded.
"""

from __future__ import annotations

import argparse
import dataclasses
from typing import TYPE_CHECKING, Any

from .. import exitcodes
from ..io import add_request_arguments, dump_json, emit, run_request_command

if TYPE_CHECKING:
    from kfio import Budget
    from kfio.model import Request

#: ``--exact`` without ``options.simulate.exact_steps`` enumerates at most 2^16 sequences.
DEFAULT_EXACT_SEQUENCES_LOG2 = 16


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "simulate",
        help="Monte Carlo of the error covariance (mean, 95%% band, percentiles)",
        description="Simulate many trajectories of the Kalman filter's error covariance over the lossy channel "
        "and report trace(P_t) over time: mean with a 95% band, median, 90% and 99%. "
        "Flags override options.simulate of the request. Exit 0 ok, 2 invalid input, 4 budget exceeded.",
    )
    add_request_arguments(p)
    p.add_argument("--steps", type=int, metavar="T", help="horizon (default 200, at most 10000)")
    p.add_argument(
        "--trajectories", type=int, metavar="M", help="number of trajectories (default 10000 within the work cap)"
    )
    p.add_argument("--seed", type=int, metavar="S", help="random seed (default 0); same seed, same output")
    p.add_argument(
        "--exact",
        action="store_true",
        help="also compute the exact E[P_t] by enumerating arrival sequences "
        f"(options.simulate.exact_steps, or up to 2^{DEFAULT_EXACT_SEQUENCES_LOG2} sequences)",
    )
    p.set_defaults(func=_run, quick_exit=True)


def with_overrides(request: Request, args: argparse.Namespace) -> Request:
    """The request with command-line flags written into ``options.simulate``."""
    from kfio.simulation import packets_of

    raw: dict[str, Any] = dict(request.options.get("simulate", {}))
    for key in ("steps", "trajectories", "seed"):
        val = getattr(args, key)
        if val is not None:
            raw[key] = val
    if args.exact and "exact_steps" not in raw:
        cap = DEFAULT_EXACT_SEQUENCES_LOG2 // len(packets_of(request))
        steps = raw.get("steps", 200)
        raw["exact_steps"] = min(steps, cap) if type(steps) is int else cap
    return dataclasses.replace(request, options={**request.options, "simulate": raw})


def _run(args: argparse.Namespace) -> int:
    from kfio.simulation import simulate

    def work(request: Request, budget: Budget) -> int:
        report = simulate(with_overrides(request, args), budget=budget)
        emit(dump_json(report.to_dict()) if args.json else report.summary())  # emit: user text made safe
        return exitcodes.STABLE

    return run_request_command(args, work)
