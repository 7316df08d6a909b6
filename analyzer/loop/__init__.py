"""Closed loops over lossy networks: sensor and actuator packets lost, fixed gains, exact answers.

The loop ``x[t+1] = A x + B a + w``, ``y = C x + v`` with the sensor packets
on one channel and the actuator packets on another (Schenato, Sinopoli,
Franceschetti, Poolla and Sastry 2007) is a Markov jump linear system;
its mean-square stability, stationary cost and the critical reliability of
each link are decided exactly over Q (Costa, Fragoso and Marques 2005).
See ``docs/loop.md``.
"""

from __future__ import annotations

import sys
import types
from typing import Any

from ._cost import stationary_cost
from ._critical import parameter_of
from ._mjls import loop_mjls, sensor_links
from ._model import LoopRequest, load_loop_request, parse_loop_request
from ._region import region
from ._report import LoopReport, analyze_loop, loop, loop_report_view, loop_request
from ._verdict import decide

__all__ = [
    "LoopReport",
    "LoopRequest",
    "analyze_loop",
    "decide",
    "load_loop_request",
    "loop",
    "loop_mjls",
    "loop_report_view",
    "loop_request",
    "parameter_of",
    "parse_loop_request",
    "region",
    "sensor_links",
    "stationary_cost",
]


class _CallableModule(types.ModuleType):
    """``kfio.loop`` is both this package and the function :func:`loop`: calling the package calls it."""

    def __call__(self, *args: Any, **kwargs: Any) -> LoopReport:
        return loop(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
