"""The JSON view of ``kfio loop``: the exact verdict first, cost and critical link reliabilities beside it."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ..loop import LoopReport


def loop_report(r: LoopReport) -> dict[str, Any]:
    """``kfio loop --json``."""
    from ..loop import loop_report_view

    return loop_report_view(r)
