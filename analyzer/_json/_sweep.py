"""The JSON views of ``kfio sweep``: one row per point, and the table with how it ran."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ..sweep import coordinate_column

if TYPE_CHECKING:
    from ..sweep import SweepResult, SweepRow


def _coordinate(v: Any) -> Any:
    """An axis value as the request had it: text, an integer or ``null`` as given, anything else as text."""
    return v if isinstance(v, (str, int, type(None))) else str(v)


def sweep_row(r: SweepRow) -> dict[str, Any]:
    """One finished point: its index, its coordinates (``axis:<name>``, exact value texts) and the key fields."""
    return {"index": r.index, **{coordinate_column(k): _coordinate(v) for k, v in r.coordinates.items()}, **r.fields}


def sweep_result(s: SweepResult) -> dict[str, Any]:
    """The sweep as JSON: how it ran, its columns and one record per point (index order)."""
    return {
        "command": s.spec.command,
        "points": len(s.rows),
        "errors": sum(1 for r in s.rows if r.fields.get("error")),
        "stopped": s.stopped,
        "engine": s.engine,
        "workers": s.workers,
        "tasks": s.chunks,
        "seconds": round(s.seconds, 3),
        "columns": s.columns,
        "rows": s.records(),
    }


__all__ = ["sweep_result", "sweep_row"]
