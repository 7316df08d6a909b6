"""Evaluate a chunk of sweep points: the task one Dask worker runs.

What does not change between points is computed once per worker process:

* the FMO blocks (eigenstructure, reduced blocks) depend on ``A``, ``C`` and
  the sensor split only, so a sweep that varies the channel derives them once
  (:func:`kfio.stability.analyze` takes them as ``fmo=``);
* the verdict does not depend on ``Q`` and ``R``: for ``analyze``, points that
  differ only there share one row.

Both caches are bounded (least recently used), keyed by exact values.
"""

from __future__ import annotations

import pickle
import time
from typing import Any, Sequence

from .._budget import Budget
from .._reuse import LRU, clear_plants, reused_plant, structure_cache
from ..errors import AnalyzerError, AssumptionViolation, BudgetExceeded, InvalidInput, NumericalFailure
from ..model import DEFAULT_LIMITS, load_json
from ._parse import parse_point
from ._rows import analyze_row, error_row, row_from_report
from ._spec import SweepSpec, parse_sweep, point_at

_STRUCTURE = structure_cache()
_VERDICT_ROWS: LRU[dict[str, Any]] = LRU(4096)
_SPECS: LRU[SweepSpec] = LRU(8)


def cache_stats() -> dict[str, int]:
    """Hits and misses of this process's reuse caches (for benchmarks and tests)."""
    return {
        "structure_hits": _STRUCTURE.hits,
        "structure_misses": _STRUCTURE.misses,
        "verdict_hits": _VERDICT_ROWS.hits,
        "verdict_misses": _VERDICT_ROWS.misses,
    }


def clear_caches() -> None:
    """Forget every cached structure and verdict (tests, benchmarks)."""
    for c in (_STRUCTURE, _VERDICT_ROWS):
        c.clear()
    clear_plants()


def _without_noise(tree: Any) -> Any:
    if not isinstance(tree, dict) or not isinstance(tree.get("system"), dict):
        return tree
    system = {k: v for k, v in tree["system"].items() if k not in ("Q", "R")}
    return {**tree, "system": system}


def evaluate_point(command: str, tree: Any, budget_s: float, *, reuse: bool = True) -> dict[str, Any]:
    """The row of one point (never raises for an analysis failure: the row names it)."""
    try:
        if command == "loop":  # a closed loop (kfio.loop): the same report as ``kfio loop --json``
            from ..loop import analyze_loop, parse_loop_request

            return row_from_report(command, analyze_loop(parse_loop_request(tree)).to_dict())
        request = parse_point(tree, DEFAULT_LIMITS.for_command(command))
        budget = Budget(seconds=budget_s)
        if command == "analyze":
            from ..stability import analyze

            if not reuse:
                return row_from_report(command, analyze(request, budget).to_dict())

            def run() -> dict[str, Any]:
                fmo, memo = reused_plant(request.system, budget)
                return analyze_row(
                    analyze(request, budget, fmo=fmo, memo=memo, tail="kappa")
                )  # the row prints kappa alone

            key = pickle.dumps(_without_noise(tree), protocol=pickle.HIGHEST_PROTOCOL)  # equal pickles: equal trees
            return dict(_VERDICT_ROWS.get(key, run))
        if command == "bounds":
            from ..riccati_bounds import compute_bounds

            return row_from_report(command, compute_bounds(request, budget=budget).to_dict())
        from ..simulation import simulate

        return row_from_report(command, simulate(request, budget=budget).to_dict())
    except BudgetExceeded as exc:
        return error_row(command, "budget-exceeded", str(exc))
    except NumericalFailure as exc:
        return error_row(command, "numerical-failure", str(exc))
    except AssumptionViolation as exc:
        return error_row(command, "assumption-violation", f"{exc.field}: {exc.rule}")
    except InvalidInput as exc:
        return error_row(command, "invalid-input", f"{exc.field}: {exc.rule}")
    except AnalyzerError as exc:
        return error_row(command, "analysis-error", str(exc))
    except Exception as exc:  # noqa: BLE001 - one bad point must not end the sweep; the row says it is a bug
        return error_row(command, "internal", f"{type(exc).__name__}: {exc}")


def _spec(spec_text: str) -> SweepSpec:
    return _SPECS.get(spec_text, lambda: parse_sweep(load_json(spec_text)))


def evaluate_chunk(
    spec_text: str, indices: Sequence[int], deadline: float | None, reuse: bool = True
) -> list[tuple[int, dict[str, Any]]]:
    """Rows of the points ``indices`` of the sweep ``spec_text`` (canonical sweep JSON).

    Workers rebuild each point from the sweep itself (:func:`point_at`), so a
    task carries a few integers, not a million requests.  ``deadline`` is the
    sweep's total budget as a wall-clock epoch (``time.time()``); points
    reached after it get a ``budget-exceeded`` row.
    """
    spec = _spec(spec_text)
    out = []
    for i in indices:
        budget_s = spec.point_budget_s
        if deadline is not None:
            left = deadline - time.time()
            if left <= 0:
                out.append((i, error_row(spec.command, "budget-exceeded", "the sweep's time budget ran out")))
                continue
            budget_s = min(budget_s, left)
        out.append((i, evaluate_point(spec.command, point_at(spec, i).request, budget_s, reuse=reuse)))
    return out
