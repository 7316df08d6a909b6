"""``kfio.loop``: the exact verdict, cost and critical link reliabilities of a closed loop.

One code path for the three doors: :func:`loop` (Python), ``kfio loop FILE``
and ``POST /v1/loop`` all validate a loop request with
:func:`kfio.loop._model.parse_loop_request` and call :func:`analyze_loop`.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Callable, Mapping

from .._budget import Budget
from .._reporting import Report
from ..errors import BudgetExceeded
from ..model import MarkovChannel, PerSensorChannel, Request, fraction_text
from ._cost import stationary_cost
from ._critical import Critical, critical_value, parameter_of
from ._mjls import Mjls, estimator_mjls, loop_mjls, sensor_links
from ._model import LoopRequest
from ._region import region
from ._verdict import decide

#: Exact fraction texts longer than this are left out of the report (the float stays).
MAX_EXACT_TEXT = 2000

THEOREM = "Costa, Fragoso and Marques 2005, Theorem 3.9 (mean-square stability of Markov jump linear systems)"
MODEL = "Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. II (sensor and actuator packet losses)"


def _text(x: Fraction | None) -> str | None:
    if x is None:
        return None
    t = fraction_text(x)
    return t if len(t) <= MAX_EXACT_TEXT else None


def _matrix(m: Any) -> list[list[str]]:
    return [[fraction_text(x) for x in row] for row in m]


@dataclass(frozen=True, repr=False)
class LoopReport(Report):
    """The report of :func:`loop`: ``to_dict()`` is the JSON of ``kfio loop --json`` and ``POST /v1/loop``.

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
        With ``controller.lqg``: the control MARE's critical actuator probability ``nu_c`` (exact for
        square invertible ``B`` and scalar plants, else a bracket) and ``cost_bounds``, the bounds
        ``J_min <= J_inf <= J_max`` on the optimal TCP-like cost (:mod:`kfio.loop._lqg_bounds`).
    partial:
        ``True`` when the time budget ran out after the verdict and cost: the notes name what is missing.
    udp_region_bounds:
        With ``protocol: udp``: outer and inner bounds on the optimal UDP-like controller's critical
        region (:mod:`kfio.loop._udp_bounds`), labelled as bounds.
    region:
        With ``options.loop.region``: the exact boundary of the stable region in the
        (sensor, actuator) arrival-probability plane (:mod:`kfio.loop._region`).
    """

    verdict: str
    exact: bool
    certified: bool
    certificate: str
    spectral_radius: float
    spectral_radius_exact: str | None
    operator_size: int
    modes: int
    stationary_cost: Fraction | None
    critical: tuple[Critical, ...]
    sensor_critical: Critical | None
    actuator_critical: Critical | None
    estimator_alone: dict[str, Any]
    request: LoopRequest
    region: dict[str, Any] | None
    lqg: dict[str, Any] | None = None
    notes: tuple[str, ...] = field(default=())
    udp_region_bounds: dict[str, Any] | None = None
    partial: bool = False

    _repr_fields = ("verdict", "spectral_radius", "cost")

    @property
    def cost(self) -> float | None:
        """The stationary cost in float64 (``None`` when unbounded); exactly: :attr:`stationary_cost`."""
        return None if self.stationary_cost is None else float(self.stationary_cost)

    @property
    def cost_exact(self) -> str | None:
        """The stationary cost as exact fraction text (``None`` when unbounded or longer than 2000 characters)."""
        return _text(self.stationary_cost)

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


def loop_report_view(r: LoopReport) -> dict[str, Any]:
    """The JSON fields of a :class:`LoopReport` (encoded by :func:`kfio._json.encode`)."""
    req = r.request
    return {
        "verdict": r.verdict,
        "theorem": THEOREM,
        "model": MODEL,
        "exact": r.exact,
        "certified": r.certified,
        "certificate": r.certificate,
        "partial": r.partial,
        "spectral_radius": r.spectral_radius,
        "spectral_radius_exact": r.spectral_radius_exact,
        "operator_size": r.operator_size,
        "modes": r.modes,
        "cost": r.cost,
        "cost_exact": r.cost_exact,
        "critical_sensor_arrival_probability": r.critical_sensor_arrival_probability,
        "critical_sensor_arrival_probability_exact": r.critical_sensor_arrival_probability_exact,
        "critical_actuator_arrival_probability": r.critical_actuator_arrival_probability,
        "critical_actuator_arrival_probability_exact": r.critical_actuator_arrival_probability_exact,
        "critical_values": [c.as_dict() for c in r.critical],
        "estimator_alone": r.estimator_alone,
        "region": r.region,
        "lqg": r.lqg,
        "udp_region_bounds": r.udp_region_bounds,
        "loop": {
            "protocol": req.protocol,
            "on_loss": req.on_loss,
            "form": req.form,
            "controller": req.controller,
            "K": _matrix(req.K),
            "L": _matrix(req.L),
        },
        "notes": list(r.notes),
    }


def _bernoulli_only(ch: MarkovChannel) -> bool:
    return ch.model == "bernoulli"


def _optimal_filter_critical(req: LoopRequest) -> tuple[float | None, str | None, str | None]:
    """The optimal time-varying filter's critical arrival probability (``kfio.analyze``, Theorem 1)."""
    if isinstance(req.channel, PerSensorChannel) or req.channel.model != "bernoulli":
        return None, None, "defined for one Bernoulli sensor packet"
    from .._api import analyze
    from ..errors import AnalyzerError

    try:
        rep = analyze(Request(system=req.system, channel=req.channel))
    except AnalyzerError as exc:
        return None, None, str(exc)
    return rep.critical_arrival_probability, rep.critical_arrival_probability_exact, None


def _estimator_alone(req: LoopRequest, with_critical: bool, budget: Budget | None = None) -> dict[str, Any]:
    sys = estimator_mjls(req)
    dec = decide(sys, budget)
    trace = stationary_cost(sys, dec.moments) if dec.moments is not None else None
    crit = None
    links = sensor_links(req)
    if with_critical and len(links) == 1:
        lk = links[0][0]
        crit = critical_value(
            lk.label, lk.pointer, lk.channel, lambda ch: estimator_mjls(req, {lk.pointer: ch}), budget
        )
    opt, opt_exact, why = _optimal_filter_critical(req)
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
    return {
        "verdict": dec.verdict,
        "spectral_radius": dec.spectral_radius,
        "spectral_radius_exact": dec.spectral_radius_exact,
        "stationary_error_trace": None if trace is None else float(trace),
        "stationary_error_trace_exact": _text(trace),
        "critical_sensor_arrival_probability": crit.value
        if crit and crit.parameter.endswith("arrival_probability")
        else None,
        "critical_sensor_arrival_probability_exact": crit.exact
        if crit and crit.parameter.endswith("arrival_probability")
        else None,
        "critical_value": crit.as_dict() if crit else None,
        "optimal_filter_critical_arrival_probability": opt,
        "optimal_filter_critical_arrival_probability_exact": opt_exact,
        "optimal_filter_note": why,
        "statement": statement,
    }


#: Largest second-moment operator (``modes * d (d + 1) / 2``) a loop request may need: beyond it even
#: the float margin (a dense eigenvalue problem) would not fit a worker's memory and time.
MAX_OPERATOR_SIZE = 3000


def _lqg_part(req: LoopRequest, budget: Budget | None, with_bounds: bool = True) -> dict[str, Any] | None:
    """For LQG gains: the control MARE's critical actuator probability and the optimal cost's bounds (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V)."""
    if req.controller != "lqg":
        return None
    from ._lqg import control_critical
    from ._lqg_bounds import lqg_cost_bounds, unavailable

    if not with_bounds:
        return {**control_critical(req), "cost_bounds": unavailable("not computed: the time budget ran out")}
    return {**control_critical(req), "cost_bounds": lqg_cost_bounds(req, budget)}


def _udp_part(req: LoopRequest, verdict: str) -> dict[str, Any]:
    """Bounds on the optimal UDP-like critical region, and where the request's point falls (:mod:`kfio.loop._udp_bounds`)."""
    from ._udp_bounds import udp_region_bounds

    out = udp_region_bounds(req, _optimal_filter_critical(req))
    outer = out["outer"]
    if verdict == "stable":
        out["request_point_inside_optimal_region"] = True  # the inner bound: these gains are stable here
    elif outer is not None and not isinstance(req.channel, PerSensorChannel):
        lam, nu = req.channel.table[0], req.actuator.table[0]  # Bernoulli links: checked by udp_region_bounds
        g, n_ = outer["sensor_arrival_probability_above"], outer["actuator_arrival_probability_above"]
        if (g is not None and float(lam) < g) or (n_ is not None and float(nu) < n_):
            out["request_point_inside_optimal_region"] = False
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
    if skipped:
        notes.append("partial: the time budget ran out; not computed: " + "; ".join(skipped))
    return LoopReport(
        verdict=dec.verdict,
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
    )


def _skipped_critical(label: str, pointer: str, ch: MarkovChannel) -> Critical:
    par = parameter_of(pointer, ch)
    return Critical(label, par[0] if par else pointer, None, None, (), "not computed: the time budget ran out")


def loop(
    system: Any,
    controller: Mapping[str, Any],
    channel: Any,
    actuator_channel: Any,
    *,
    B: Any = None,
    Q: Any = None,
    R: Any = None,
    cost: Mapping[str, Any] | None = None,
    protocol: str = "tcp",
    on_loss: str = "zero",
    budget: Any = None,
) -> LoopReport:
    """Exact mean-square stability, cost and critical link reliabilities of a loop closed over lossy links.

    The plant ``x[t+1] = A x + B a + w``, ``y = C x + v`` is observed through
    the sensor packets (``channel``) and actuated through the actuator packets
    (``actuator_channel``), with fixed gains ``K`` (estimator) and ``L``
    (``u = -L x_hat``) as python-control's ``dlqe`` and ``dlqr`` return them
    (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. II).  The
    loop is a Markov jump linear system; it is mean-square stable iff the
    spectral radius of its second-moment operator is below 1 (Costa,
    Fragoso and Marques 2005, Thm 3.9), decided exactly over Q.

    Parameters
    ----------
    system:
        A :class:`kfio.System` with ``Q`` and ``R`` (then ``B`` is required),
        or a discrete-time python-control ``StateSpace`` (``A``, ``B``, ``C``
        from it; ``Q`` and ``R`` as keywords).
    controller:
        ``{"K": ..., "L": ..., "form": "predictor" | "filter"}``, or the
        request's ``{"gains": {"K": ..., "L": ...}, "form": ...}``, or
        ``{"lqg": {"W": ..., "U": ...}}``.
    channel, actuator_channel:
        Channels as for :func:`kfio.analyze` (``kfio.bernoulli(0.9)``, ...);
        the actuator's is a one-packet channel.
    cost:
        ``{"W": ..., "U": ...}`` weighing ``x' W x + a' U a`` (default ``W = I``, ``U = 0``).
    protocol, on_loss:
        ``"tcp"`` (acknowledged actuator packets) or ``"udp"``; ``"zero"``
        (a lost input is zero) or ``"hold"`` (the last input is held).
    budget:
        Seconds (as ``options.time_budget_s``, in ``[0.01, 3600]``) or a
        :class:`kfio.Budget`, as for :func:`kfio.analyze`: the verdict raises
        :class:`kfio.errors.BudgetExceeded` if it does not fit; later parts
        are left out of a ``partial`` report.

    Returns
    -------
    LoopReport
        ``to_dict()`` is the JSON of ``kfio loop --json`` for :func:`loop_request` of the same arguments.
    """
    from ._model import parse_loop_request

    work = budget if isinstance(budget, Budget) else None
    tree = loop_request(
        system,
        controller,
        channel,
        actuator_channel,
        B=B,
        Q=Q,
        R=R,
        cost=cost,
        protocol=protocol,
        on_loss=on_loss,
        budget=None if work is not None else budget,
    )
    return analyze_loop(parse_loop_request(tree), budget=work)


def loop_request(
    system: Any,
    controller: Mapping[str, Any],
    channel: Any,
    actuator_channel: Any,
    *,
    B: Any = None,
    Q: Any = None,
    R: Any = None,
    cost: Mapping[str, Any] | None = None,
    protocol: str = "tcp",
    on_loss: str = "zero",
    budget: Any = None,
) -> dict[str, Any]:
    """The loop request file (JSON-ready dict) for the arguments of :func:`loop` (``budget`` in seconds)."""
    from .._system import System
    from ..errors import InvalidInput
    from ..model import channel_tree, json_ready, python_tree

    if isinstance(system, System):
        sys_tree = system.to_dict()
        if B is None:
            raise InvalidInput("B", "a loop needs the input matrix B (or pass a python-control StateSpace)")
        sys_tree["B"] = python_tree(B)
        for key, val in (("Q", Q), ("R", R)):
            if val is not None:
                sys_tree[key] = python_tree(val)
    elif all(hasattr(system, a) for a in ("A", "B", "C", "dt")):
        plant = System.from_statespace(system, Q=Q, R=R)
        sys_tree = plant.to_dict()
        sys_tree["B"] = python_tree(system.B if B is None else B)
    else:
        raise InvalidInput(
            "system", f"expected a kfio.System or a python-control StateSpace; got a {type(system).__name__}"
        )
    ctrl = python_tree(dict(controller))
    if isinstance(ctrl, dict) and "K" in ctrl and "L" in ctrl:
        ctrl = {"gains": {"K": ctrl.pop("K"), "L": ctrl.pop("L")}, **ctrl}
    tree: dict[str, Any] = {
        "system": sys_tree,
        "channel": channel_tree(channel, bernoulli_number=True),
        "actuator_channel": channel_tree(actuator_channel, bernoulli_number=True),
        "controller": ctrl,
    }
    if cost is not None:
        tree["cost"] = python_tree(dict(cost))
    tree["options"] = {"loop": {"protocol": protocol, "on_loss": on_loss}}
    if budget is not None:
        tree["options"]["time_budget_s"] = python_tree(budget)
    return json_ready(tree)


__all__ = ["LoopReport", "analyze_loop", "loop", "loop_report_view", "loop_request"]
