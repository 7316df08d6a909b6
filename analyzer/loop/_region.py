"""The stable region of a loop in the plane of its two links' arrival probabilities (Bernoulli x Bernoulli).

For each sensor arrival probability ``lam_i`` of a grid, the exact critical
actuator arrival probability ``nu_c(lam_i)`` (:mod:`kfio.loop._critical`): the
points ``(lam_i, nu_c(lam_i))`` lie exactly on the boundary curve
``det(I - T(lam, nu)) = 0`` where the loop changes verdict (Schenato,
Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V, draw this region for
the optimal design; this is the region of the given gains).
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

from .._budget import Budget
from .._reporting import ReportPart
from ..model import MarkovChannel, PerSensorChannel
from ._critical import Critical, critical_value, parameter_of
from ._mjls import Mjls, loop_mjls
from ._model import MAX_REGION_POINTS, LoopRequest


@dataclass(frozen=True)
class BoundaryPoint(ReportPart):
    """A point ``(lam, nu_c(lam))`` of the boundary: the exact critical actuator value at one sensor value."""

    sensor: Fraction
    critical: Critical

    @property
    def sensor_arrival_probability(self) -> float:
        return float(self.sensor)

    @property
    def critical_actuator_arrival_probability(self) -> float | None:
        return self.critical.value

    @property
    def critical_actuator_arrival_probability_exact(self) -> str | None:
        return self.critical.exact


@dataclass(frozen=True)
class Region(ReportPart):
    """The boundary of the stable region in the (sensor, actuator) arrival-probability plane."""

    boundary: tuple[BoundaryPoint, ...]


def _bernoulli(x: Fraction) -> MarkovChannel:
    """The Bernoulli channel with arrival probability ``x`` (the channel :func:`parameter_of` builds)."""
    found = parameter_of("/channel", MarkovChannel("bernoulli", 0, (x,), {"arrival_probability": x}))
    assert found is not None  # a Bernoulli channel always has its arrival probability
    return found[1](x)


def region(req: LoopRequest, points: int, budget: Budget | None = None) -> Region | None:
    """``points`` sensor probabilities ``(i + 1/2) / points`` and the exact critical actuator probability at each.

    ``budget`` (:class:`kfio.Budget`) is checked at every point; :class:`kfio.errors.BudgetExceeded` when spent.
    """
    if (
        isinstance(req.channel, PerSensorChannel)
        or req.channel.model != "bernoulli"
        or req.actuator.model != "bernoulli"
    ):
        return None
    rows = []
    for i in range(points):
        lam = Fraction(2 * i + 1, 2 * points)

        def build(ch: MarkovChannel, lam: Fraction = lam) -> Mjls:
            return loop_mjls(req, {"/channel": _bernoulli(lam), "/actuator_channel": ch})

        rows.append(BoundaryPoint(lam, critical_value("actuator", "/actuator_channel", req.actuator, build, budget)))
    return Region(tuple(rows))


__all__ = ["MAX_REGION_POINTS", "BoundaryPoint", "Region", "region"]
