"""A verdict at a stated confidence: does the whole confidence region of a fitted channel lie in the stable set?

The region is the Bonferroni box of :class:`kfio.fit.FitReport` (each of the
``m`` parameters at level ``1 - (1 - level) / m``).  Its corners are rounded
outward to 12 significant digits, so every corner is an exact rational and
the box checked contains the statistical one; kfio's exact verdict (Rohr,
Marelli and Fu 2014, Theorem 1 for ``kfio analyze``; Costa, Fragoso and
Marques 2005, Thm 3.9 for ``kfio loop``) is evaluated at them:

* ``stable`` when the worst corner (lowest arrival and recovery
  probabilities, highest failure rate) and every other corner checked are
  stable; ``unstable`` when the best corner and every other corner checked are
  unstable; ``undecided`` otherwise.
* Bernoulli, ``kfio analyze``: the stable set is ``lambda > lambda_c``
  (Corollary 2), so the two ends decide the interval exactly.
* Bernoulli link, ``kfio loop``: the verdict can change only at a root of
  ``det(I - T(lambda))``; the loop report isolates those roots, and an
  interval holding one is ``undecided`` whatever its ends say.
* Gilbert-Elliott and Markov: the stable set need not be monotone in every
  parameter (``|alpha|^4 ((1 - q)^2 + p q) < 1`` grows with ``q`` when
  ``p > 2 (1 - q)``), so besides the worst and best corners every corner of
  the box is checked (at most 16; beyond, the two extreme corners and 14 drawn
  at random).  A box none of whose corners disagree is decided; this is exact
  where the stable set is monotone over the box and a stated check otherwise.

``samples_needed``: the half-widths shrink like ``1 / sqrt(N)``; with ``s*``
the largest shrink factor of the box about the estimate at which the deciding
corner still has the estimate's verdict (bisection, exact verdicts),
``N_needed = N / s*^2``: for Bernoulli ``N ((lambda_hat - lower) / (lambda_hat - lambda_c))^2``.
"""

from __future__ import annotations

import itertools
import math
import random
from collections.abc import Callable
from dataclasses import dataclass
from decimal import ROUND_CEILING, ROUND_FLOOR, Context, Decimal
from fractions import Fraction
from typing import Any

from .._numbers import number_text
from .._reporting import ReportPart
from ..errors import AssumptionViolation
from ._fit import FitReport, channel_of
from ._intervals import interval_method

#: Significant digits of the rounded corners.
CORNER_DIGITS = 12
#: Every corner is checked when the box has at most this many; beyond, :data:`SAMPLED_CORNERS` of them.
MAX_CORNERS = 16
SAMPLED_CORNERS = 16
#: Bisection steps of the shrink factor behind ``samples_needed``.
BISECTIONS = 20

#: ``evaluate(channel object) -> "stable" | "unstable" | "boundary"``.
Evaluate = Callable[[dict[str, Any]], str]


def _outward(x: Fraction, down: bool) -> Fraction:
    """``x`` rounded to :data:`CORNER_DIGITS` significant digits, down or up, clamped to ``[0, 1]``."""
    if x <= 0:
        return Fraction(0)
    if x >= 1:
        return Fraction(1)
    ctx = Context(prec=CORNER_DIGITS, rounding=ROUND_FLOOR if down else ROUND_CEILING)
    d = ctx.divide(Decimal(x.numerator), Decimal(x.denominator))
    return min(max(Fraction(d), Fraction(0)), Fraction(1))


def _worse_is_higher(name: str) -> bool:
    """A failure rate is worse when higher; an arrival or recovery probability when lower."""
    return name == "failure_rate"


@dataclass(frozen=True, repr=False)
class ConfidenceVerdict(ReportPart):
    """The ``fit`` block of ``kfio analyze|loop --trace``: the verdict of the whole confidence region.

    Attributes
    ----------
    link:
        The request's channel the trace was fitted to (``/channel``, ``/actuator_channel``).
    verdict:
        ``stable``, ``unstable`` or ``undecided``.
    samples_needed:
        Trace length at which the box, shrinking like ``1 / sqrt(N)`` about
        the estimate, would decide; ``None`` when decided, or when the
        estimate itself is on the boundary.
    corners:
        The worst and best corners (channel objects) and their exact verdicts.
    """

    link: str
    fit: FitReport
    level: Fraction
    intervals: dict[str, tuple[float, float]]
    interval_method: str
    verdict: str
    samples_needed: int | None
    corners: dict[str, Any]
    method: str
    warnings: tuple[str, ...] = ()

    def summary_lines(self) -> list[str]:
        """Lines for the terminal summary of ``kfio analyze|loop``."""
        f = self.fit
        head = f.model + (f" order {f.order}" if f.model == "markov" else "")
        pct = f"{float(self.level) * 100:g}%"
        lines = [
            f"trace ({self.link}): {head} fitted to {f.samples} packets; at {pct} confidence: {self.verdict.upper()}"
        ]
        for name, (lo, hi) in self.intervals.items():
            lines.append(
                f"  {name} = {number_text(f.parameters[name], float(f.estimates[name]))}, box [{lo:.6g}, {hi:.6g}]"
            )
        if self.samples_needed is not None:
            lines.append(
                f"  about {self.samples_needed} packets in all would decide (the box shrinking like 1/sqrt(N))"
            )
        lines += [f"  warning: {w}" for w in f.warnings + self.warnings]
        return lines


class _Box:
    """The rounded box of a fit, shrunk by a factor ``s`` about the estimate."""

    def __init__(self, fit: FitReport, intervals: dict[str, tuple[float, float]]) -> None:
        self.fit = fit
        self.names = list(fit.trials)
        self.centre = {n: fit.estimates[n] for n in self.names}
        self.lo = {n: _outward(Fraction(intervals[n][0]), True) for n in self.names}
        self.hi = {n: _outward(Fraction(intervals[n][1]), False) for n in self.names}

    def corner(self, s: Fraction, choice: dict[str, bool]) -> dict[str, Fraction]:
        """The corner taking the upper end of ``n`` where ``choice[n]``, the box shrunk by ``s``."""
        out = {}
        for n in self.names:
            c = self.centre[n]
            if choice[n]:
                out[n] = _outward(c + s * (self.hi[n] - c), False)
            else:
                out[n] = _outward(c - s * (c - self.lo[n]), True)
        return out

    def worst(self) -> dict[str, bool]:
        return {n: _worse_is_higher(n) for n in self.names}

    def best(self) -> dict[str, bool]:
        return {n: not _worse_is_higher(n) for n in self.names}

    def choices(self) -> list[dict[str, bool]]:
        """Every corner when there are at most :data:`MAX_CORNERS`, else the extremes and a seeded sample."""
        m = len(self.names)
        if 1 << m <= MAX_CORNERS:
            return [dict(zip(self.names, bits)) for bits in itertools.product((False, True), repeat=m)]
        rng = random.Random(m)  # fixed seed: the same request gives the same report
        out = [self.worst(), self.best()]
        while len(out) < SAMPLED_CORNERS:
            out.append({n: rng.random() < 0.5 for n in self.names})
        return out

    def channel(self, values: dict[str, Fraction]) -> dict[str, Any]:
        return channel_of(self.fit.model, self.fit.order, values)


def _verdict_at(evaluate: Evaluate, box: _Box, values: dict[str, Fraction]) -> str | None:
    """The exact verdict at a corner, ``None`` when a probability there is 0 or 1 (outside Assumption 1)."""
    if any(v in (0, 1) for v in values.values()):
        return None
    try:
        return evaluate(box.channel(values))
    except AssumptionViolation:
        return None


def _decides(evaluate: Evaluate, box: _Box, s: Fraction, choice: dict[str, bool], target: str) -> bool:
    return _verdict_at(evaluate, box, box.corner(s, choice)) == target


def _samples_needed(evaluate: Evaluate, box: _Box, point: str, samples: int) -> int | None:
    """``ceil(N / s^2)`` for the largest shrink factor ``s`` found at which the deciding corner keeps ``point``."""
    if point not in ("stable", "unstable"):
        return None
    choice = box.worst() if point == "stable" else box.best()
    good, bad = Fraction(0), Fraction(1)
    for _ in range(BISECTIONS):
        mid = (good + bad) / 2
        if _decides(evaluate, box, mid, choice, point):
            good = mid
        else:
            bad = mid
    if good == 0:
        return None
    return math.ceil(samples / (good * good))


def confidence_verdict(
    fit: FitReport,
    evaluate: Evaluate,
    point: str,
    *,
    link: str = "/channel",
    level: Fraction | None = None,
    roots: tuple[float, ...] | None = None,
    method: str,
) -> ConfidenceVerdict:
    """The verdict of the whole confidence box of ``fit`` (module docstring).

    Parameters
    ----------
    fit:
        The fitted channel.
    evaluate:
        kfio's exact verdict for a channel object in place of the fitted one.
    point:
        The exact verdict at the estimate (the report's headline).
    level:
        Joint level of the box (default: the fit's).
    roots:
        For a one-parameter link, the points where the verdict may change
        (``None``: not known); an interval holding one is undecided.
    method:
        How the region is decided, for the report.
    """
    lvl = fit.level if level is None else level
    intervals = fit.joint_intervals(lvl)
    box = _Box(fit, intervals)
    worst, best = box.worst(), box.best()
    at_worst = _verdict_at(evaluate, box, box.corner(Fraction(1), worst))
    at_best = _verdict_at(evaluate, box, box.corner(Fraction(1), best))
    verdict = "undecided"
    warnings: list[str] = []
    if at_worst == "stable" or at_best == "unstable":
        target = "stable" if at_worst == "stable" else "unstable"
        others = [c for c in box.choices() if c not in (worst, best)]
        disagree = [c for c in others if _verdict_at(evaluate, box, box.corner(Fraction(1), c)) != target]
        inside = [r for r in roots or () if intervals[box.names[0]][0] <= r <= intervals[box.names[0]][1]]
        if not disagree and not inside:
            verdict = target
        elif disagree:
            warnings.append(
                f"{len(disagree)} corners of the box are not {target} although its extreme corner is: the stable set "
                "is not monotone over the box, so the box is undecided"
            )
        else:
            warnings.append(f"the interval holds a point where the verdict changes ({inside[0]:.6g})")
    if at_worst is None or at_best is None:
        warnings.append(
            "the box reaches a probability of 0 or 1, where Theorem 1 of Rohr, Marelli and Fu (2014) says nothing "
            "(Assumption 1); a longer trace narrows it"
        )
    needed = None if verdict != "undecided" else _samples_needed(evaluate, box, point, fit.samples)
    corners = {
        "worst": {"channel": box.channel(box.corner(Fraction(1), worst)), "verdict": at_worst},
        "best": {"channel": box.channel(box.corner(Fraction(1), best)), "verdict": at_best},
    }
    return ConfidenceVerdict(
        link=link,
        fit=fit,
        level=lvl,
        intervals=intervals,
        interval_method=interval_method(lvl, len(intervals)),
        verdict=verdict,
        samples_needed=needed,
        corners=corners,
        method=method,
        warnings=tuple(warnings),
    )


__all__ = ["CORNER_DIGITS", "ConfidenceVerdict", "Evaluate", "confidence_verdict"]
