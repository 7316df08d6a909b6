"""Which sensor's improvement lowers the worst rate most?  (Independent Bernoulli sensors; an extension.)

With per-sensor Bernoulli channels the rate of FMO block ``k`` is
``beta_k max_F prod_s (1 - lambda_s)^{z_s(F) / N_k}`` (kfio's extension of
Theorem 1 of Rohr, Marelli and Fu 2014, see :mod:`kfio.design._regions`).
For the worst block and its binding pattern ``F*``, cutting sensor ``s``'s
loss probability by a factor ``c`` multiplies the worst rate by ``c^{z_s /
N}`` as long as ``F*`` stays binding: the exact *elasticity*
``d log(rate) / d log(1 - lambda_s) = z_s(F*) / N``.  Because another pattern
or block may take over, the report also gives the worst rate after halving
each sensor's loss probability, recomputed over every block and pattern, and
names the sensor whose halving lowers it most.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Sequence

from .._reporting import ReportPart
from ._regions_constraints import BlindPattern, BlockConstraints, block_rate


def _worst(blocks: Sequence[BlockConstraints], lambdas: Sequence[float]) -> tuple[float, int | None]:
    rates = [block_rate(b, lambdas) for b in blocks]
    if not rates:
        return 0.0, None
    k = max(range(len(rates)), key=rates.__getitem__)
    return rates[k], k


@dataclass(frozen=True)
class SensorGain:
    """One sensor: the exact elasticity ``z_s(F*) / N`` and the worst rate after halving its loss probability."""

    sensor: str
    elasticity: Fraction
    worst_rate_if_loss_halved: float  # may be inf beyond float64: null in the JSON


@dataclass(frozen=True)
class SensorGains(ReportPart):
    """What :func:`sensor_gains` finds (its JSON is ``regions.sensor_improvement``).

    Attributes
    ----------
    names:
        The sensors, in the order of the blind patterns' miss counts.
    worst_rate, worst_block:
        The largest block rate at the operating point and that block's eigenvalues
        (``None`` with no block of ``|alpha| >= 1``).
    binding:
        The worst block's binding pattern ``F*`` at the operating point.
    best:
        The sensor whose halving lowers the worst rate most, or ``None`` if none lowers it.
    sensors:
        One :class:`SensorGain` per sensor.
    """

    names: tuple[str, ...]
    worst_rate: float
    worst_block: tuple[str, ...] | None
    binding: BlindPattern | None
    best: str | None
    sensors: tuple[SensorGain, ...]


def sensor_gains(blocks: Sequence[BlockConstraints], names: Sequence[str], lambdas: Sequence[Fraction]) -> SensorGains:
    """Elasticities and halving effects of each sensor on the worst block rate.

    Examples
    --------
    ``A = diag(5/2, 3/2)`` with one sensor per state at ``lambda = (9/10, 1/2)``:
    the rates are ``25/4 * 1/10 = 0.625`` and ``9/4 * 1/2 = 1.125``; only sensor 2
    sees the worst block, so only its improvement helps.

    >>> from fractions import Fraction as F
    >>> from kfio.model import Sensor, SystemRecord as System
    >>> from kfio.design._regions_constraints import block_constraints
    >>> from kfio.design._sensor_gain import sensor_gains
    >>> s = System(A=((F(5, 2), F(0)), (F(0), F(3, 2))), C=((F(1), F(0)), (F(0), F(1))),
    ...            sensors=(Sensor("s1", (0,)), Sensor("s2", (1,))))
    >>> g = sensor_gains(block_constraints(s), ["s1", "s2"], [F(9, 10), F(1, 2)])
    >>> g.best, [str(x.elasticity) for x in g.sensors]
    ('s2', ['0', '1'])
    >>> g.to_dict()["sensors"][1]["elasticity_exact"]
    '1'
    """
    lam = [float(x) for x in lambdas]
    rate, k = _worst(blocks, lam)
    if k is None:
        return SensorGains(tuple(names), 0.0, None, None, None, ())
    blk = blocks[k]
    # the binding pattern of the worst block at the operating point
    binding = max(
        blk.patterns,
        key=lambda p: sum(z * math.log(max(1e-300, 1 - x)) for z, x in zip(p.misses, lam)),
    )
    out: list[SensorGain] = []
    for s, name in enumerate(names):
        improved = list(lam)
        improved[s] = 1 - (1 - lam[s]) / 2
        after, _ = _worst(blocks, improved)
        out.append(SensorGain(name, Fraction(binding.misses[s], blk.period), after))
    best = min(range(len(out)), key=lambda i: out[i].worst_rate_if_loss_halved)
    return SensorGains(
        names=tuple(names),
        worst_rate=rate,
        worst_block=blk.eigenvalues,
        binding=binding,
        best=out[best].sensor if out[best].worst_rate_if_loss_halved < rate else None,
        sensors=tuple(out),
    )


__all__ = ["SensorGain", "SensorGains", "sensor_gains"]
