"""The stable region of a loop in the plane of its two links' arrival probabilities (Bernoulli x Bernoulli).

For each sensor arrival probability ``lam_i`` of a grid, the exact critical
actuator arrival probability ``nu_c(lam_i)`` (:mod:`kfio.loop._critical`): the
points ``(lam_i, nu_c(lam_i))`` lie exactly on the boundary curve
``det(I - T(lam, nu)) = 0`` where the loop changes verdict (Schenato,
Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V, draw this region for
the optimal design; this is the region of the given gains).
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

from .._budget import Budget
from ..model import MarkovChannel, PerSensorChannel
from ._critical import critical_value
from ._mjls import Mjls, loop_mjls
from ._model import MAX_REGION_POINTS, LoopRequest


def _bernoulli(x: Fraction) -> MarkovChannel:
    return MarkovChannel("bernoulli", 0, (x,), {"arrival_probability": x})


def region(req: LoopRequest, points: int, budget: Budget | None = None) -> dict[str, Any] | None:
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

        c = critical_value("actuator", "/actuator_channel", req.actuator, build, budget)
        rows.append(
            {
                "sensor_arrival_probability": float(lam),
                "sensor_arrival_probability_exact": f"{lam.numerator}/{lam.denominator}",
                "critical_actuator_arrival_probability": c.value,
                "critical_actuator_arrival_probability_exact": c.exact,
                "note": None if c.value is not None else c.note,
            }
        )
    return {
        "boundary": rows,
        "rule": "stable iff the actuator arrival probability exceeds the critical value at that sensor "
        "arrival probability (null: no actuator probability stabilizes the loop there)",
    }


__all__ = ["MAX_REGION_POINTS", "region"]
