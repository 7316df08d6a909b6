"""The JSON views of ``kfio check``: one outcome per requirement, and the result with its counts."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ..check import CheckResult, Outcome


def outcome(o: Outcome) -> dict[str, Any]:
    """One requirement of one entry: status, measured and required texts, why, how long its run took."""
    return {
        "entry": o.entry,
        "requirement": o.requirement,
        "status": o.status,
        "measured": o.measured,
        "required": o.required,
        "detail": o.detail,
        "seconds": round(o.seconds, 3),
        "error_kind": o.error_kind,
    }


def check_result(r: CheckResult) -> dict[str, Any]:
    """The JSON of ``kfio check --json``: the status, the counts and every outcome in the file's order."""
    tally = r.tally
    return {
        "command": "check",
        "source": r.source,
        "status": r.status,
        "requirements": len(r.outcomes),
        "passed": tally["pass"],
        "failed": tally["fail"],
        "errors": tally["error"],
        "seconds": round(r.seconds, 3),
        "workers": r.workers,
        "outcomes": r.outcomes,
    }


__all__ = ["check_result", "outcome"]
