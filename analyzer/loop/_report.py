"""``kfio.loop``: the exact verdict, cost and critical link reliabilities of a closed loop.

One code path for the three doors: :func:`kfio.loop` (Python), ``kfio loop FILE``
and ``POST /v1/loop`` all validate a loop request with
:func:`kfio.loop._model.parse_loop_request` and call :func:`analyze_loop`.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Callable

from .._budget import Budget
from .._reporting import Report
from .._verdicts import Verdict
from ..errors import BudgetExceeded
from ..model import (
    MAX_EXACT_DIGITS,
    MarkovChannel,
    PerSensorChannel,
    Request,
    capped_fraction_text,
    decimal_enclosure,
)
from ._cost import stationary_cost
from ._critical import Critical, critical_value, parameter_of
from ._lqg_types import LqgPart
from ._mjls import Mjls, estimator_mjls, loop_mjls, sensor_links
from ._model import LoopRequest
from ._parts import EstimatorAlone, OptimalFilter
from ._region import Region, region
from ._udp_bounds import UdpRegionBounds
from ._verdict import decide

LQG_PAPER = "Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V"


def _text(x: Fraction | None) -> str | None:
    """The exact text, or ``None`` past :data:`kfio.model.MAX_EXACT_DIGITS` digits (never a 4300-digit crash)."""
    return capped_fraction_text(x)[0]


def _enclosure(box: tuple[Fraction, Fraction] | None) -> list[str] | None:
    return None if box is None else list(decimal_enclosure(*box))


@dataclass(frozen=True, repr=False)
class LoopReport(Report):
    """The report of :func:`kfio.loop`: ``to_dict()`` is the JSON of ``kfio loop --json`` and ``POST /v1/loop``.

    Attributes
    ----------
    verdict:
        ``stable`` (``rho(T) < 1``), ``boundary`` (``= 1``) or ``unstable``,
        decided exactly over Q (Costa, Fragoso and Marques 2005, Thm 3.9).
    spectral_radius, spectral_radius_exact:
        ``rho(T)`` in float64, and exactly when rational or quadratic.
    cost, cost_exact:
        The stationary ``lim E[x' W x + a' U a]``; ``None`` when unbounded.
    critical:
        Critical value of each link alone (:class:`kfio.loop._critical.Critical`).
    estimator_alone:
        The fixed estimator gain without control, beside the optimal filter's critical value.
    lqg:
        With ``controller.lqg`` (:class:`kfio.loop._lqg_types.LqgPart`): the optimal TCP-like
        controller's verdict, critical sensor and actuator probabilities (the control MARE's exact for
        one input, square invertible ``B`` and scalar plants, Elia 2005, else a bracket) and the bounds
        ``J_min <= J_inf <= J_max`` on its cost (:mod:`kfio.loop._lqg_bounds`); the top level is the
        exact analysis of the stationary gains, or, below the optimal critical values, ``unstable``
        without gains (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V).
    partial:
        ``True`` when the time budget ran out after the verdict and cost: the notes name what is missing.
    udp_region_bounds:
        With ``protocol: udp``: outer and inner bounds on the optimal UDP-like controller's critical
        region (:mod:`kfio.loop._udp_bounds`), labelled as bounds.
    region:
        With ``options.loop.region``: the exact boundary of the stable region in the
        (sensor, actuator) arrival-probability plane (:mod:`kfio.loop._region`).
    """

    verdict: Verdict
    exact: bool
    certified: bool
    certificate: str
    spectral_radius: float | None
    spectral_radius_exact: str | None
    operator_size: int
    modes: int
    stationary_cost: Fraction | None
    critical: tuple[Critical, ...]
    sensor_critical: Critical | None
    actuator_critical: Critical | None
    estimator_alone: EstimatorAlone | None
    request: LoopRequest
    region: Region | None
    lqg: LqgPart | None = None
    notes: tuple[str, ...] = field(default=())
    udp_region_bounds: UdpRegionBounds | None = None
    partial: bool = False
    spectral_radius_enclosure: tuple[Fraction, Fraction] | None = None
    certified_cost: float | None = None
    certified_cost_enclosure: tuple[Fraction, Fraction] | None = None

    _repr_fields = ("verdict", "spectral_radius", "cost")

    @property
    def cost(self) -> float | None:
        """The stationary cost in float64 (``None`` when unbounded); exactly: :attr:`stationary_cost`.

        On the certified route (no exact moments) the float cost of the float moments, inside :attr:`cost_enclosure`.
        """
        if self.stationary_cost is None:
            return self.certified_cost
        return float(self.stationary_cost)

    @property
    def cost_exact(self) -> str | None:
        """The stationary cost as exact fraction text; ``None`` when unbounded, not computed, or over 200 digits."""
        return _text(self.stationary_cost)

    @property
    def cost_exact_digits(self) -> int | None:
        """Digits of the exact cost's text (``None`` when it was not computed)."""
        return capped_fraction_text(self.stationary_cost)[1]

    @property
    def cost_enclosure(self) -> list[str] | None:
        """Decimal texts ``[lo, hi]`` proved to enclose the cost: when the exact text is capped, or on the certified route."""
        if self.stationary_cost is not None:
            box = capped_fraction_text(self.stationary_cost)[2]
            return list(box) if box is not None else None
        return _enclosure(self.certified_cost_enclosure)

    @property
    def critical_sensor_arrival_probability(self) -> float | None:
        """Critical arrival probability of the (one, Bernoulli) sensor link, the rest fixed."""
        return self.sensor_critical.value if self.sensor_critical else None

    @property
    def critical_sensor_arrival_probability_exact(self) -> str | None:
        return self.sensor_critical.exact if self.sensor_critical else None

    @property
    def critical_actuator_arrival_probability(self) -> float | None:
        """Critical arrival probability of the (Bernoulli) actuator link, the rest fixed."""
        return self.actuator_critical.value if self.actuator_critical else None

    @property
    def critical_actuator_arrival_probability_exact(self) -> str | None:
        return self.actuator_critical.exact if self.actuator_critical else None


def _optimal_filter_critical(req: LoopRequest) -> OptimalFilter:
    """The optimal time-varying filter's critical arrival probability (``kfio.analyze``, Theorem 1)."""
    if isinstance(req.channel, PerSensorChannel) or req.channel.model != "bernoulli":
        return OptimalFilter(None, None, "defined for one Bernoulli sensor packet")
    from ..errors import AnalyzerError
    from ..stability import analyze

    try:
        rep = analyze(Request(system=req.system, channel=req.channel))
    except AnalyzerError as exc:
        return OptimalFilter(None, None, str(exc))
    return OptimalFilter(rep.critical_arrival_probability, _capped_text(rep.critical_arrival_probability_exact), None)


def _capped_text(text: str | None) -> str | None:
    """An exact (algebraic) text, or ``None`` when it holds more than :data:`kfio.model.MAX_EXACT_DIGITS` digits."""
    if text is None or sum(ch.isdigit() for ch in text) > MAX_EXACT_DIGITS:
        return None
    return text


def _estimator_alone(req: LoopRequest, with_critical: bool, budget: Budget | None = None) -> EstimatorAlone:
    sys = estimator_mjls(req)
    dec = decide(sys, budget)
    trace = stationary_cost(sys, dec.moments) if dec.moments is not None else None
    trace_float = float(trace) if trace is not None else dec.cost
    crit = None
    links = sensor_links(req)
    if with_critical and len(links) == 1:
        lk = links[0][0]
        crit = critical_value(
            lk.label, lk.pointer, lk.channel, lambda ch: estimator_mjls(req, {lk.pointer: ch}), budget
        )
    optimal = _optimal_filter_critical(req)
    opt, opt_exact = optimal.critical_arrival_probability, optimal.critical_arrival_probability_exact
    mine = None
    if crit is not None and crit.value is not None:
        short = crit.exact is not None and len(crit.exact) <= 24
        mine = crit.exact if short else f"{crit.value:.4g}"
    statement = None
    if (
        opt_exact is not None
        and mine is not None
        and crit is not None
        and crit.parameter.endswith("arrival_probability")
    ):
        theirs = opt_exact if len(opt_exact) <= 24 or opt is None else f"{opt:.4g}"
        statement = f"the optimal time-varying filter needs {theirs}; your steady-state gain needs {mine}"
    return EstimatorAlone(
        verdict=Verdict(dec.verdict),
        spectral_radius=dec.spectral_radius,
        spectral_radius_exact=dec.spectral_radius_exact,
        stationary_error_trace=trace_float,
        stationary_error_trace_exact=_text(trace),
        critical=crit,
        optimal_filter=optimal,
        statement=statement,
    )


#: Largest second-moment operator (``modes * d (d + 1) / 2``) a loop request may need: beyond it even
#: the float margin (a dense eigenvalue problem) would not fit a worker's memory and time.
MAX_OPERATOR_SIZE = 3000


def _lqg_part(req: LoopRequest, budget: Budget | None, with_bounds: bool = True) -> LqgPart | None:
    """For LQG gains: the optimal TCP-like controller beside the stationary gains (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V)."""
    if req.controller != "lqg":
        return None
    from ._lqg import lqg_part

    return lqg_part(req, budget, with_bounds)


def _without_gains(req: LoopRequest) -> LoopReport:
    """The report below the optimal TCP-like critical values: ``unstable``, no gains, no cost, the reasons in the notes.

    No TCP-like controller, optimal or stationary, has a bounded cost there
    (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V), so there is no loop to analyze.
    """
    from ._lqg import with_statement

    part = _lqg_part(req, None)
    assert part is not None
    part = with_statement(part, (None, None), (None, None))
    notes = (
        "no stationary TCP-like gains exist: " + "; ".join(part.optimal.reasons),
        f"the verdict is that of the optimal TCP-like controller ({LQG_PAPER}); lqg.optimal gives its critical values",
    )
    return LoopReport(
        verdict=Verdict.UNSTABLE,
        exact=True,
        certified=True,
        certificate="below the optimal TCP-like critical values (" + LQG_PAPER + ")",
        spectral_radius=None,
        spectral_radius_exact=None,
        operator_size=0,
        modes=0,
        stationary_cost=None,
        critical=(),
        sensor_critical=None,
        actuator_critical=None,
        estimator_alone=None,
        request=req,
        region=None,
        lqg=part,
        notes=notes,
    )


def _udp_part(req: LoopRequest, verdict: str) -> UdpRegionBounds:
    """Bounds on the optimal UDP-like critical region, and where the request's point falls (:mod:`kfio.loop._udp_bounds`)."""
    from ._udp_bounds import udp_region_bounds

    out = udp_region_bounds(req, _optimal_filter_critical(req))
    outer = out.outer
    if verdict == "stable":  # the inner bound: these gains are stable here
        return dataclasses.replace(out, request_point_inside_optimal_region=True)
    if outer is not None and not isinstance(req.channel, PerSensorChannel):
        lam, nu = req.channel.table[0], req.actuator.table[0]  # Bernoulli links: checked by udp_region_bounds
        g, n_ = outer.sensor_arrival_probability_above, outer.actuator_arrival_probability_above
        if (g is not None and float(lam) < g) or (n_ is not None and float(nu) < n_):
            return dataclasses.replace(out, request_point_inside_optimal_region=False)
    return out


def analyze_loop(req: LoopRequest, *, critical: bool = True, budget: Budget | None = None) -> LoopReport:
    """The whole report for a validated loop request (module docstring of :mod:`kfio.loop`).

    ``budget`` (:class:`kfio.Budget`; by default ``options.time_budget_s`` of the request, else none)
    bounds the exact work.  The verdict and cost come first: if the budget runs out before them,
    :class:`kfio.errors.BudgetExceeded`; if it runs out later, the report is ``partial`` and its
    notes name what was not computed (critical values, region, LQG cost bounds).
    """
    from ..errors import LimitExceeded
    from ._mjls import loop_state_size, sensor_links

    if req.controller == "lqg" and not req.K:
        return _without_gains(req)
    d = loop_state_size(req)
    modes = 1
    for lk in [lk for lk, _ in sensor_links(req)] + [None]:
        ch = lk.channel if lk is not None else req.actuator
        modes *= 1 if ch.order == 0 else ch.n_histories
    size = modes * d * (d + 1) // 2
    if size > MAX_OPERATOR_SIZE:
        raise LimitExceeded(
            "/system/A",
            f"the loop's second-moment operator would have size {size} ({modes} channel modes x {d * (d + 1) // 2} "
            f"coordinates of a {d}x{d} symmetric matrix); the limit is {MAX_OPERATOR_SIZE}: use fewer states or "
            "channels of lower order",
        )
    work = budget if budget is not None else (Budget(seconds=req.time_budget_s) if req.time_budget_s else None)
    sys = loop_mjls(req)
    dec = decide(sys, work)  # the headline: no partial answer without it
    cost = stationary_cost(sys, dec.moments) if dec.moments is not None else None
    skipped: list[str] = []

    def attempt(what: str, fn: Callable[[], Any], fallback: Callable[[], Any]) -> Any:
        """``fn()``, or ``fallback()`` once the budget is spent (the report is then partial and says what is missing)."""
        try:
            return fn()
        except BudgetExceeded as exc:
            skipped.append(f"{what} ({exc})")
            return fallback()

    crits: list[Critical] = []
    sensor_c = actuator_c = None
    notes = []
    if critical:
        links = [(lk.label, lk.pointer, lk.channel) for lk, _rows in sensor_links(req)]
        links.append(("actuator", "/actuator_channel", req.actuator))
        for label, pointer, channel in links:

            def build(ch: MarkovChannel, p: str = pointer) -> Mjls:
                return loop_mjls(req, {p: ch})

            crits.append(
                attempt(
                    f"critical value of {pointer}",
                    functools.partial(critical_value, label, pointer, channel, build, work),
                    functools.partial(_skipped_critical, label, pointer, channel),
                )
            )
        ac = crits[-1]
        if len(crits) == 2 and crits[0].parameter.endswith("arrival_probability"):
            sensor_c = crits[0]
        if ac.parameter.endswith("arrival_probability"):
            actuator_c = ac
    udp_bounds = None
    if req.protocol == "udp":
        udp_bounds = _udp_part(req, dec.verdict)
        notes.append(
            "UDP-like: the estimator does not know whether the actuator packet arrived and uses the link's "
            "long-run arrival rate; the verdict is exact for these fixed gains (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. VI)"
        )
    alone = attempt(
        "estimator-alone critical value",
        lambda: _estimator_alone(req, critical, work),
        lambda: _estimator_alone(req, False, None),
    )
    reg = None
    if req.region is not None:
        reg = attempt("region", lambda: region(req, req.region or 0, work), lambda: None)
    lqg = attempt("LQG cost bounds", lambda: _lqg_part(req, work), lambda: _lqg_part(req, None, with_bounds=False))
    if lqg is not None:
        from ._lqg import with_statement

        lqg = with_statement(
            lqg,
            (sensor_c.value, sensor_c.exact) if sensor_c else (None, None),
            (actuator_c.value, actuator_c.exact) if actuator_c else (None, None),
        )
    if skipped:
        notes.append("partial: the time budget ran out; not computed: " + "; ".join(skipped))
    return LoopReport(
        verdict=Verdict(dec.verdict),
        exact=dec.exact,
        certified=dec.certified,
        certificate=dec.certificate,
        spectral_radius=dec.spectral_radius,
        spectral_radius_exact=dec.spectral_radius_exact,
        operator_size=dec.size,
        modes=sys.modes,
        stationary_cost=cost,
        critical=tuple(crits),
        sensor_critical=sensor_c,
        actuator_critical=actuator_c,
        estimator_alone=alone,
        request=req,
        region=reg,
        lqg=lqg,
        notes=tuple(notes),
        udp_region_bounds=udp_bounds,
        partial=bool(skipped),
        spectral_radius_enclosure=dec.radius_enclosure,
        certified_cost=dec.cost,
        certified_cost_enclosure=dec.cost_enclosure,
    )


def _skipped_critical(label: str, pointer: str, ch: MarkovChannel) -> Critical:
    par = parameter_of(pointer, ch)
    return Critical(label, par[0] if par else pointer, None, None, (), "not computed: the time budget ran out")


__all__ = ["LoopReport", "analyze_loop"]
