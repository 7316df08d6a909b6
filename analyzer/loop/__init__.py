"""Closed loops over lossy networks: sensor and actuator packets lost, fixed gains, exact answers.

The loop ``x[t+1] = A x + B a + w``, ``y = C x + v`` with the sensor packets
on one channel and the actuator packets on another (Schenato, Sinopoli,
Franceschetti, Poolla and Sastry 2007) is a Markov jump linear system;
its mean-square stability, stationary cost and the critical reliability of
each link are decided exactly over Q (Costa, Fragoso and Marques 2005).
See ``docs/loop.md``.

``kfio.loop`` (the attribute of the package ``kfio``) is the typed function
:func:`loop`; this subpackage stays importable under the same name
(``from kfio.loop import analyze_loop``).  Its names load on first use, so
importing it costs nothing until then: ``kfio`` imports it at start-up to
keep the function, not the subpackage, as its attribute.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_names

#: Public name -> the private module (relative to this package) that defines it.
_LAZY = {
    "BoundaryPoint": "._region",
    "EstimatorAlone": "._parts",
    "LoopReport": "._report",
    "LoopRequest": "._model",
    "OptimalFilter": "._parts",
    "Region": "._region",
    "UdpOuterBound": "._udp_bounds",
    "UdpRegionBounds": "._udp_bounds",
    "analyze_loop": "._report",
    "decide": "._verdict",
    "load_loop_request": "._model",
    "loop": "._api",
    "loop_mjls": "._mjls",
    "loop_request": "._api",
    "parameter_of": "._critical",
    "parse_loop_request": "._model",
    "region": "._region",
    "sensor_links": "._mjls",
    "stationary_cost": "._cost",
}

if TYPE_CHECKING:
    from ._api import loop, loop_request
    from ._cost import stationary_cost
    from ._critical import parameter_of
    from ._mjls import loop_mjls, sensor_links
    from ._model import LoopRequest, load_loop_request, parse_loop_request
    from ._parts import EstimatorAlone, OptimalFilter
    from ._region import BoundaryPoint, Region, region
    from ._report import LoopReport, analyze_loop
    from ._udp_bounds import UdpOuterBound, UdpRegionBounds
    from ._verdict import decide


__getattr__, __dir__ = lazy_names(__name__, _LAZY, globals())


__all__ = [
    "BoundaryPoint",
    "EstimatorAlone",
    "LoopReport",
    "LoopRequest",
    "OptimalFilter",
    "Region",
    "UdpOuterBound",
    "UdpRegionBounds",
    "analyze_loop",
    "decide",
    "load_loop_request",
    "loop",
    "loop_mjls",
    "loop_request",
    "parameter_of",
    "parse_loop_request",
    "region",
    "sensor_links",
    "stationary_cost",
]
