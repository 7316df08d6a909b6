"""Exact stable regions of independent Bernoulli sensors: an **extension** of Rohr, Marelli and Fu (2014), Theorem 1.

Liu and Goldsmith (2004) (Liu and Goldsmith) brackets the stable throughput region of a
multi-sensor Kalman filter between a lower bound (``prod_s (1 - lambda_s)
rho(A)^2 >= 1`` is unstable, its Theorem 3) and an LMI upper bound (its
eq. (20), Theorem 5), and leaves the band in between undecided.  Rohr, Marelli and Fu (2014)'s
FMO construction (Theorem 1, Lemma 3, Corollary 2) carries over to packets
lost separately (docs/theory.md, "Beyond the seeds"): per FMO block ``k``,

.. math::

    (|\\alpha_k|^2 \\sigma_k)^{N_k} = \\beta_k^{N_k}
        \\max_{F} \\prod_s (1 - \\lambda_s)^{z_s(F)},

``F`` over the maximal blind (phase, sensor) patterns and ``z_s(F)`` the
phases at which sensor ``s`` is not in ``F``
(:mod:`kfio.design._regions_constraints`).  The filter is stable iff every block
has rate ``< 1``, unstable if one has ``> 1``, and ``= 1`` is the theorem's
gap (``boundary``).  **This is not a theorem of the seeds**; every result
here carries ``"basis": "extension"``.  The tests check it against Liu and Goldsmith (2004)'s
bounds (it must lie between them), Liu and Goldsmith (2004)'s cases with a known answer, a
brute-force blind probability, and simulation.

What this module adds to the per-block verdict of :func:`kfio.analyze`:

* :func:`sensor_thresholds`: for each sensor ``s``, the exact critical
  arrival probability given the others,
  ``lambda_{s,c} = max(0, max_{k,F: z_s > 0} 1 - (beta_k^{N_k}
  prod_{r != s} (1 - lambda_r)^{z_r})^{-1/z_s})``, or none when a pattern
  with ``z_s = 0`` already has rate ``>= 1`` (no ``lambda_s`` helps);
  for one sensor this is Rohr, Marelli and Fu (2014)'s ``1 - beta^{-N/z*}``;
* :func:`exact_region_grid`: for two sensors, the ``K x K`` square labelled
  exactly (the grid of Liu and Goldsmith (2004)'s Figs. 4-5 and of ``kfio bounds --grid K``)
  and the closed-form boundary curve (:mod:`kfio.design._regions_curve`);
* :func:`region_report`: the JSON block for the ``analyze`` report.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Sequence

import mpmath
import sympy

from .._budget import Budget
from .._json import encode
from .._reporting import ReportPart
from .._verdicts import Verdict
from ..errors import InvalidInput
from ..model import PerSensorChannel, Request, packets_of, require_assumption_1, value_text
from ..sigma import VERDICTS, SigmaResult
from ..structure import DIGITS, FmoBlock
from ._regions_constraints import (
    SEPARATION,
    BlindPattern,
    BlockConstraints,
    block_constraints,
    block_rate,
    block_sign,
    loss_product,
    power_expr,
    rate_sign,
    rational,
)
from ._regions_curve import DEFAULT_SAMPLES, BoundaryCurve, boundary_curve
from ._sensor_gain import sensor_gains


def bernoulli_packets(request: Request) -> tuple[tuple[str, ...], tuple[Fraction, ...]]:
    """Sensor names and arrival probabilities; every channel must be i.i.d. (order 0).

    Raises
    ------
    InvalidInput
        A channel with memory (field ``/channel/...``).
    """
    pairs = [(p.name if p.name is not None else "packet", p.channel, p.where) for p in packets_of(request)]
    for name, c, where in pairs:
        if c.order != 0:
            raise InvalidInput(
                f"{where}/model",
                f"exact stable regions need i.i.d. (Bernoulli) channels; sensor {name!r} has a {c.model} channel of order {c.order}",
            )
    return tuple(n for n, _, _ in pairs), tuple(c.table[0] for _, c, _ in pairs)


@dataclass(frozen=True)
class SensorThreshold:
    """The critical arrival probability of one sensor, the others held at their values.

    Attributes
    ----------
    sensor, arrival_probability:
        The sensor and its probability in the request.
    status:
        ``"threshold"``: stable iff ``lambda_s > critical`` (``= critical`` is
        the boundary); ``"zero"``: every ``lambda_s`` in ``(0, 1)`` is stable;
        ``"none"``: no ``lambda_s`` makes the filter stable.
    critical, critical_exact:
        ``lambda_{s,c}`` as a float and as an exact SymPy text (``None`` for
        ``"none"``).
    binding:
        ``(block index, eigenvalues, pattern)`` of the constraint that decides.
    certified:
        Every comparison behind the answer was exact.
    reason:
        One sentence.
    """

    sensor: str
    arrival_probability: Fraction
    status: str
    critical: float | None
    critical_exact: str | None
    binding: tuple[int, tuple[str, ...], BlindPattern] | None
    certified: bool
    reason: str


@dataclass(frozen=True)
class SensorThresholds(ReportPart):
    """Per-sensor exact thresholds and the verdict at the request's operating point (extension)."""

    sensors: tuple[str, ...]
    arrival: tuple[Fraction, ...]
    blocks: tuple[BlockConstraints, ...]
    block_verdicts: tuple[str, ...]
    block_rates: tuple[float, ...]
    verdict: Verdict
    thresholds: tuple[SensorThreshold, ...]
    certified: bool
    consistent_with_analyze: bool | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "verdict", Verdict(self.verdict))


def _log_value(block: BlockConstraints, rest: Fraction, z: int) -> Any:
    """``log((beta^N rest)^(1/z))``: larger means a larger threshold ``1 - exp(-value)``."""
    with mpmath.workdps(DIGITS + 10):
        return (block.log_beta_power() + mpmath.log(mpmath.mpf(rest.numerator) / rest.denominator)) / z


def _exact_greater(a: tuple[BlockConstraints, Fraction, int], b: tuple[BlockConstraints, Fraction, int]) -> int | None:
    """Sign of ``(beta_a^N_a P_a)^(z_b) - (beta_b^N_b P_b)^(z_a)`` when both ``beta`` are rational, else ``None``."""
    (ba, Pa, za), (bb, Pb, zb) = a, b
    if ba.beta is None or bb.beta is None or ba.beta.rational is None or bb.beta.rational is None:
        return None
    va = (ba.beta.rational**ba.period * Pa) ** zb
    vb = (bb.beta.rational**bb.period * Pb) ** za
    return (va > vb) - (va < vb)


def _threshold(blocks: Sequence[BlockConstraints], lambdas: Sequence[Fraction], s: int, name: str) -> SensorThreshold:
    """``lambda_{s,c}`` given the other sensors (module docstring)."""
    exact = all(b.certified for b in blocks)
    best: tuple[Any, int, BlindPattern, Fraction] | None = None
    for k, b in enumerate(blocks):
        for p in b.patterns:
            rest = loss_product(p.misses, lambdas, skip=s)
            if rest == 0:
                continue  # another sensor with lambda_r = 1 observes this pattern away
            sign, ex = rate_sign(b, rest)
            exact = exact and ex
            z = p.misses[s]
            if z == 0:
                if sign >= 0:
                    what = "has rate exactly 1 (boundary)" if sign == 0 else "is unstable"
                    reason = (
                        f"block {', '.join(b.eigenvalues)} {what} for every lambda of sensor {name!r}: the blind "
                        f"pattern {sorted(p.slots)} never needs it"
                    )
                    return SensorThreshold(name, lambdas[s], "none", None, None, (k, b.eigenvalues, p), exact, reason)
                continue
            if sign <= 0:
                continue  # holds at lambda_s = 0 already
            lv = _log_value(b, rest, z)
            if best is not None:
                diff = lv - best[0]
                if abs(diff) <= SEPARATION:
                    order = _exact_greater((b, rest, z), (blocks[best[1]], best[3], best[2].misses[s]))
                    if order is None:
                        exact = False  # equal to 40 digits: either choice gives the same value
                        continue
                    if order <= 0:
                        continue
                elif diff < 0:
                    continue
            best = (lv, k, p, rest)
    if best is None:
        reason = (
            f"every constraint holds at lambda = 0 for sensor {name!r}: stable for any arrival probability in (0, 1)"
        )
        return SensorThreshold(name, lambdas[s], "zero", 0.0, "0", None, exact, reason)
    lv, k, p, rest = best
    b = blocks[k]
    expr = 1 - (power_expr(b) * rational(rest)) ** sympy.Rational(-1, p.misses[s])
    with mpmath.workdps(DIGITS):
        value = float(-mpmath.expm1(-lv))
    reason = (
        f"stable iff lambda({name}) > the critical value; set by block {', '.join(b.eigenvalues)} and blind pattern "
        f"{sorted(p.slots)}"
    )
    return SensorThreshold(name, lambdas[s], "threshold", value, str(expr), (k, b.eigenvalues, p), exact, reason)


def _operating_point(blocks: Sequence[BlockConstraints], lambdas: Sequence[Fraction]) -> tuple[list[Verdict], bool]:
    verdicts: list[Verdict] = []
    exact = True
    for b in blocks:
        s, ex = block_sign(b, lambdas)
        verdicts.append(Verdict.of_sign(s))
        exact = exact and ex
    return verdicts, exact


def _consistent(report: Any, verdict: str, blocks: Sequence[BlockConstraints], verdicts: Sequence[str]) -> bool:
    """Whether an :class:`kfio.stability._verdict.StabilityReport` agrees, overall and block by block."""
    if report.verdict != verdict:
        return False
    mine = {b.eigenvalues: v for b, v in zip(blocks, verdicts)}
    for br in report.blocks:
        if br.rate is None:
            continue
        if br.eigenvalues in mine and mine[br.eigenvalues] != br.verdict:
            return False
    return True


def sensor_thresholds(
    request: Request,
    report: Any = None,
    budget: Budget | None = None,
    *,
    fmo: Sequence[FmoBlock] | None = None,
    sigma: Sequence[SigmaResult | None] | None = None,
) -> SensorThresholds:
    """Exact critical arrival probability of each Bernoulli sensor given the others (extension).

    .. math::

        \\lambda_{s,c} = \\max\\Bigl(0, \\max_{k, F:\\ z_s(F) > 0}
        1 - \\bigl(\\beta_k^{N_k} \\prod_{r \\ne s} (1 - \\lambda_r)^{z_r(F)}\\bigr)^{-1/z_s(F)}\\Bigr)

    and ``"none"`` when a pattern with ``z_s(F) = 0`` has
    ``beta_k^{N_k} prod_{r != s} (1 - lambda_r)^{z_r} >= 1``.  With one sensor
    this is Rohr, Marelli and Fu (2014)'s ``lambda_c = 1 - beta^{-N/z*}`` (Corollary 2 with
    Theorem 1), and the ``analyze`` report's
    ``critical_arrival_probability``.

    Parameters
    ----------
    request:
        A validated request whose channels are all Bernoulli: a
        ``per_sensor`` channel with ``system.sensors``, or one packet.
    report:
        Optional :class:`kfio.stability._verdict.StabilityReport` of the same
        request; its verdicts are compared with the ones found here
        (``consistent_with_analyze``).
    budget:
        Work budget for the eigenstructure and the blind-set enumeration.
    fmo, sigma:
        ``fmo_blocks(request.system)`` and their ``compute_sigma`` results,
        if already computed (see :func:`kfio.design._regions_constraints.block_constraints`).

    Returns
    -------
    SensorThresholds

    Raises
    ------
    InvalidInput
        A channel with memory.
    AssumptionViolation
        An arrival probability of 0 or 1 (Rohr, Marelli and Fu (2014), Assumption 1).

    Examples
    --------
    Liu and Goldsmith (2004), Case 1 (``C_1 = I``, ``C_2`` invertible): ``lambda_2c = 1 - 1 / (1.25^2 (1 - lambda_1))``.

    >>> from kfio import load_request
    >>> req = load_request('{"system": {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 0], [0, 1], [1, 0], [1, 1]],'
    ...     ' "sensors": [{"name": "s1", "rows": [0, 1]}, {"name": "s2", "rows": [2, 3]}]},'
    ...     ' "channel": {"model": "per_sensor", "channels": {"s1": {"model": "bernoulli", "arrival_probability": 0.2},'
    ...     ' "s2": {"model": "bernoulli", "arrival_probability": 0.5}}}}')
    >>> th = sensor_thresholds(req)
    >>> th.thresholds[1].critical_exact, 1 - 1 / (1.25**2 * 0.8)
    ('1/5', 0.19999999999999996)
    """
    require_assumption_1(request.channel)
    names, lambdas = bernoulli_packets(request)
    blocks = block_constraints(request.system, budget, fmo, sigma)
    verdicts, exact = _operating_point(blocks, lambdas)
    verdict = max(verdicts, key=VERDICTS.index, default=Verdict.STABLE)
    rates = tuple(block_rate(b, [float(x) for x in lambdas]) for b in blocks)
    thresholds = tuple(_threshold(blocks, lambdas, s, name) for s, name in enumerate(names))
    certified = exact and all(t.certified for t in thresholds) and all(b.certified for b in blocks)
    return SensorThresholds(
        sensors=names,
        arrival=lambdas,
        blocks=blocks,
        block_verdicts=tuple(verdicts),
        block_rates=rates,
        verdict=verdict,
        thresholds=thresholds,
        certified=certified,
        consistent_with_analyze=None if report is None else _consistent(report, verdict, blocks, verdicts),
    )


@dataclass(frozen=True)
class RegionGrid(ReportPart):
    """The ``(lambda_1, lambda_2)`` square labelled exactly (extension), with the boundary curve.

    ``labels[i][j]`` is the cell ``lambda_1 = values[i]``, ``lambda_2 =
    values[j]``: the indexing of :class:`kfio.riccati_bounds._report.RegionMap`,
    so the two maps compare cell by cell.
    """

    axes: tuple[str, str]
    values: tuple[Fraction, ...]
    labels: tuple[tuple[str, ...], ...]
    certified: bool
    curve: BoundaryCurve


def _two_sensors(request: Request) -> tuple[str, str]:
    names, _ = bernoulli_packets(request)
    if len(names) != 2:
        raise InvalidInput(
            "/system/sensors", f"the region map needs exactly two sensors; this request has {len(names)}"
        )
    return names[0], names[1]


def exact_region_grid(
    request: Request,
    K: int,
    values: Sequence[Fraction] | None = None,
    budget: Budget | None = None,
    *,
    samples: int = DEFAULT_SAMPLES,
    fmo: Sequence[FmoBlock] | None = None,
    sigma: Sequence[SigmaResult | None] | None = None,
) -> RegionGrid:
    """Label the ``K x K`` grid of ``(lambda_1, lambda_2)`` exactly: stable / unstable / boundary.

    The cell ``(values[i], values[j])`` is stable iff every FMO block has
    ``beta^N prod_s (1 - lambda_s)^{z_s(F)} < 1`` for every blind pattern
    ``F``, decided in exact arithmetic (:func:`kfio.design._regions_constraints.rate_sign`).

    Parameters
    ----------
    request:
        Two sensors with Bernoulli channels (their probabilities are ignored).
    K:
        Side of the grid, ``K >= 2``; the default values are ``i / (K - 1)``,
        the grid of ``kfio bounds --grid K``.
    values:
        Other exact grid values in ``[0, 1]`` (then ``K`` must equal their number).
    budget:
        Work budget.
    samples:
        Samples of the boundary curve ``h`` on ``[0, 1]``.
    fmo, sigma:
        ``fmo_blocks(request.system)`` and their ``compute_sigma`` results, if already computed.

    Raises
    ------
    InvalidInput
        Not two Bernoulli sensors, ``K < 2``, or values outside ``[0, 1]``.

    Examples
    --------
    Liu and Goldsmith (2004), Section VI.B: ``A = diag(2.5, 1.5)``, exact region ``lambda_1 > 21/25``, ``lambda_2 > 5/9``.

    >>> from kfio import load_request
    >>> req = load_request('{"system": {"A": [[2.5, 0], [0, 1.5]], "C": [[1, 0], [0, 1]],'
    ...     ' "sensors": [{"name": "s1", "rows": [0]}, {"name": "s2", "rows": [1]}]},'
    ...     ' "channel": {"model": "per_sensor", "channels": {"s1": {"model": "bernoulli", "arrival_probability": 0.9},'
    ...     ' "s2": {"model": "bernoulli", "arrival_probability": 0.6}}}}')
    >>> g = exact_region_grid(req, 3, values=[Fraction(1, 2), Fraction(21, 25), Fraction(9, 10)])
    >>> g.labels[2]
    ('unstable', 'stable', 'stable')
    >>> g.curve.envelope.lambda_1_min_exact, g.curve.envelope.segments[0].piece is not None
    ('21/25', True)
    """
    names = _two_sensors(request)
    if isinstance(K, bool) or not isinstance(K, int) or K < 2:
        raise InvalidInput("/options/regions/grid", f"the grid side must be an integer >= 2; got {value_text(K)}")
    grid = tuple(Fraction(i, K - 1) for i in range(K)) if values is None else tuple(Fraction(v) for v in values)
    if len(grid) != K:
        raise InvalidInput("/options/regions/grid", f"{len(grid)} values given for a grid of side {K}")
    if any(not 0 <= v <= 1 for v in grid):
        raise InvalidInput("/options/regions/values", "grid values must lie in [0, 1]")
    blocks = block_constraints(request.system, budget, fmo, sigma)
    certified = all(b.certified for b in blocks)
    labels = []
    for a in grid:
        row = []
        for b in grid:
            if budget is not None:
                budget.tick("exact region grid")
            worst = -1
            for blk in blocks:
                s, ex = block_sign(blk, (a, b))
                worst, certified = max(worst, s), certified and ex
            row.append(VERDICTS[worst + 1])
        labels.append(tuple(row))
    return RegionGrid(names, grid, tuple(labels), certified, boundary_curve(blocks, names, samples))


def region_report(
    request: Request,
    budget: Budget | None = None,
    *,
    report: Any = None,
    fmo: Sequence[FmoBlock] | None = None,
    sigma: Sequence[SigmaResult | None] | None = None,
) -> dict[str, Any] | None:
    """The ``regions`` block of the ``analyze`` report, or ``None`` when it does not apply.

    It applies to ``system.sensors`` with a ``per_sensor`` channel whose
    channels are all Bernoulli; other requests return ``None`` (one packet:
    the report already has ``critical_arrival_probability``; channels with
    memory: no closed form).

    Parameters
    ----------
    request:
        The validated request (Assumption 1 already checked by ``analyze``).
    budget:
        The analysis budget.
    report:
        ``analyze``'s :class:`~kfio.stability._verdict.StabilityReport`, if built
        first: its verdicts are cross-checked (``consistent_with_analyze``).
    fmo, sigma:
        ``analyze``'s ``fmo_blocks`` and, aligned with them, the
        ``compute_sigma`` result of each block (``None`` where it has none):
        with Bernoulli channels the maximal blind sets do not depend on the
        probabilities, so passing them avoids a second enumeration.

    Returns
    -------
    dict or None
        ``{"basis": "extension", "statement", "verdict", "certified",
        "consistent_with_analyze", "blocks": [constraints, verdict, rate],
        "sensors": [per-sensor thresholds], "boundary": curve (two sensors
        only, else null)}``.

    Examples
    --------
    >>> from kfio import load_request
    >>> req = load_request('{"system": {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 0], [1, 1]],'
    ...     ' "sensors": [{"name": "s1", "rows": [0]}, {"name": "s2", "rows": [1]}]},'
    ...     ' "channel": {"model": "per_sensor", "channels": {"s1": {"model": "bernoulli", "arrival_probability": 0.25},'
    ...     ' "s2": {"model": "bernoulli", "arrival_probability": 0.25}}}}')
    >>> out = region_report(req)
    >>> out["verdict"], [s["critical_arrival_probability_exact"] for s in out["sensors"]]
    ('stable', ['11/75', '21/121'])
    """
    if not isinstance(request.channel, PerSensorChannel) or request.system.sensors is None:
        return None
    if any(c.order != 0 for _, c in request.channel.channels):
        return None
    th = sensor_thresholds(request, report, budget, fmo=fmo, sigma=sigma)
    curve = boundary_curve(th.blocks, (th.sensors[0], th.sensors[1])) if len(th.sensors) == 2 else None
    gains = sensor_gains(th.blocks, th.sensors, th.arrival)
    return {**th.to_dict(), "boundary": encode(curve), "sensor_improvement": gains.to_dict()}


__all__ = [
    "RegionGrid",
    "SensorThreshold",
    "SensorThresholds",
    "bernoulli_packets",
    "exact_region_grid",
    "region_report",
    "sensor_thresholds",
]
