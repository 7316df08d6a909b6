"""``options.analyze``: the design questions a request may ask of :func:`kfio.analyze`.

* ``ge_grid`` (integer, 2..101): cells per axis of the exact Gilbert-Elliott
  (p, q) map; needs a ``gilbert_elliott`` channel.
* ``critical_parameter`` (string): a JSON pointer into ``channel`` naming one
  conditional arrival probability (``/channel/recovery_rate``,
  ``/channel/arrival_probability/01``, ...); the report gives its exact
  critical value with the others fixed.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import InvalidInput
from ..model import OPTION_KEYS, MarkovChannel, Request, option_field, option_group

_GE_GRID = option_field("analyze", "ge_grid")
#: Largest ``ge_grid``: 101 x 101 exact labels stay within a second or two.
MAX_GE_GRID = int(_GE_GRID.maximum or 0)
MIN_GE_GRID = int(_GE_GRID.minimum or 0)


@dataclass(frozen=True)
class AnalyzeOptions:
    ge_grid: int | None = None
    critical_parameter: str | None = None


def analyze_options(request: Request) -> AnalyzeOptions:
    """Validate ``options.analyze`` (unknown keys, types, ranges, and that the channel fits).

    Raises
    ------
    InvalidInput
        Naming ``/options/analyze/<key>`` and the rule.
    """
    raw = option_group(request, "analyze", OPTION_KEYS["analyze"])
    grid = raw.get("ge_grid")
    if grid is not None:
        where = "/options/analyze/ge_grid"
        if isinstance(grid, bool) or not isinstance(grid, int) or not MIN_GE_GRID <= grid <= MAX_GE_GRID:
            raise InvalidInput(where, f"ge_grid must be an integer from {MIN_GE_GRID} to {MAX_GE_GRID}")
        if not isinstance(request.channel, MarkovChannel) or request.channel.model != "gilbert_elliott":
            raise InvalidInput(where, "ge_grid needs a single gilbert_elliott channel")
    pointer = raw.get("critical_parameter")
    if pointer is not None and not isinstance(pointer, str):
        raise InvalidInput("/options/analyze/critical_parameter", "critical_parameter must be a JSON pointer string")
    return AnalyzeOptions(ge_grid=grid, critical_parameter=pointer)
