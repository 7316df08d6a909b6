"""JSON-safe numbers for the reports (JSON has no NaN or infinity)."""

from __future__ import annotations

import math
from typing import SupportsFloat


def json_float(x: SupportsFloat | None) -> float | None:
    """``float(x)``, or ``None`` when ``x`` is missing, NaN or infinite.

    Examples
    --------
    >>> json_float(0.5), json_float(float("inf")), json_float(None)
    (0.5, None, None)
    """
    if x is None:
        return None
    v = float(x)
    return v if math.isfinite(v) else None


__all__ = ["json_float"]
