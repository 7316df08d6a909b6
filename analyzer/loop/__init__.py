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


def _call_section() -> str:
    """What ``help(kfio.loop)`` shows first: the call's signature (read from :func:`loop`) and an example."""
    import inspect

    example = """
    >>> import kfio
    >>> request = {"system": {"A": [[1.25]], "B": [[1]], "C": [[1]], "Q": [[1]], "R": [[0.5]]},
    ...            "channel": {"model": "bernoulli", "arrival_probability": 0.8},
    ...            "actuator_channel": {"model": "bernoulli", "arrival_probability": 0.9},
    ...            "controller": {"lqg": {"W": [[1]], "U": [[0.5]]}}, "cost": {"W": [[1]], "U": [[0.5]]}}
    >>> str(kfio.loop.analyze_loop(kfio.loop.parse_loop_request(request)).verdict)
    'stable'
"""
    return (
        f"\n\nCalling the package calls :func:`loop`:\n\n    kfio.loop{inspect.signature(loop)}\n\n"
        f"{inspect.getdoc(loop) or ''}\n\nA loop request (the JSON of ``kfio loop``), from Python::\n{example}"
    )


__doc__ = (__doc__ or "") + _call_section()
