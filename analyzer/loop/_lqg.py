"""TCP-like LQG over lossy links: the optimal controller's verdict and the stationary gains (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V).

With a TCP-like protocol separation holds.  Over i.i.d. links with arrival
probabilities ``lam`` (sensor) and ``nu`` (actuator) the optimal controller
applies ``u = -L x_hat[t|t]``, the filtered estimate of the time-varying
Kalman filter with intermittent observations, with

* ``L = (B' S B + U)^-1 B' S A``, ``S`` the fixed point of the control MARE
  ``S = A' S A + W - nu A' S B (B' S B + U)^-1 B' S A``, which exists iff
  ``nu`` exceeds its critical value ``nu_c`` (:mod:`kfio.loop._lqg_critical`);
* an error covariance that stays bounded iff ``lam`` exceeds the critical
  value of Rohr, Marelli and Fu (2014), Theorem 1 (``kfio analyze``).

Below either critical value no TCP-like controller has a bounded cost: that
is the verdict ``unstable``, not an input error.  Above both, kfio derives the
stationary gains a team deploys: ``L`` as above and the filter gain
``K_f = P C' (C P C' + R)^-1`` with ``P`` the estimation MARE's fixed point
``P = A P A' + Q - lam A P C' (C P C' + R)^-1 C P A'`` (Sinopoli et al.
2004); in ``filter`` form (the default, the optimal controller's structure)
``K = K_f``, in ``predictor`` form ``K = A K_f``.  Both fixed points come from
:func:`kfio.riccati_bounds.mare_fixed_point` (Newton's method from stabilizing
gains, no iteration cap) in float64, and the gains are read from the shortest
decimal text of each float, as every float kfio receives; the loop with those
gains is then analyzed exactly like any other.
"""

from __future__ import annotations

import dataclasses
from decimal import Decimal
from fractions import Fraction
from typing import Any

import numpy as np

from ..errors import InvalidInput, NumericalFailure
from ..model import Matrix, PerSensorChannel, Request, fraction_text, to_float
from ._lqg_bounds import lqg_cost_bounds, lqg_floats, unavailable
from ._lqg_critical import ActuatorCritical, known_critical, largest_modulus, reaches_every_unstable_mode
from ._lqg_types import LqgCostBounds, LqgOptimal, LqgPart, RiccatiSolve

PAPER = "Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V"
THEOREM_1 = "Rohr, Marelli and Fu 2014, Theorem 1"


def _exact(m: np.ndarray) -> tuple[tuple[Fraction, ...], ...]:
    return tuple(tuple(Fraction(Decimal(repr(float(x)))) for x in row) for row in m)


def check_lqg_links(req: Any) -> None:
    """The links for which the stationary TCP-like gains are defined here, else :class:`InvalidInput` naming the field."""
    if req.protocol != "tcp":
        raise InvalidInput(
            "/controller/lqg",
            "LQG gains are defined here for the TCP-like protocol only (separation fails for UDP-like); "
            "bring fixed gains for a UDP-like loop",
        )
    if req.actuator.model != "bernoulli":
        raise InvalidInput("/actuator_channel", "LQG gains need a Bernoulli actuator channel (the control MARE's nu)")
    if isinstance(req.channel, PerSensorChannel) or req.channel.model != "bernoulli":
        raise InvalidInput("/channel", "LQG gains need one Bernoulli sensor packet (the estimation MARE's lambda)")


def _transpose(m: Matrix) -> Matrix:
    return tuple(tuple(m[j][i] for j in range(len(m))) for i in range(len(m[0])))


#: The last answers of :func:`optimal_sensor` (parsing and the report both ask; deterministic, so a repeat is the same).
_SENSOR_CACHE: dict[Any, tuple[bool, float | None, str | None, str | None]] = {}


def optimal_sensor(system: Any, channel: Any) -> tuple[bool, float | None, str | None, str | None]:
    """Whether the optimal time-varying filter keeps ``E[P]`` bounded on ``channel`` (Theorem 1, exact).

    Returns ``(stable, critical, critical_exact, note)``.
    """
    key = (system.A, system.C, channel.model, channel.table)
    hit = _SENSOR_CACHE.get(key)
    if hit is None:
        hit = _optimal_sensor(system, channel)
        if len(_SENSOR_CACHE) >= 8:
            _SENSOR_CACHE.clear()
        _SENSOR_CACHE[key] = hit
    return hit


def _optimal_sensor(system: Any, channel: Any) -> tuple[bool, float | None, str | None, str | None]:
    from ..stability import analyze

    rep = analyze(Request(system=system, channel=channel))
    note = None
    if rep.critical_arrival_probability is None and not reaches_every_unstable_mode(
        _transpose(system.A), _transpose(system.C)
    ):
        note = (
            "A has an eigenvalue with |theta| >= 1 that C does not see (an unobservable unstable mode): "
            "no sensor arrival probability keeps the estimation error bounded"
        )
    return rep.verdict == "stable", rep.critical_arrival_probability, rep.critical_arrival_probability_exact, note


#: The last answers of :func:`actuator_critical` (parsing and the report both ask; a bracket costs an LMI search).
_ACTUATOR_CACHE: dict[Any, ActuatorCritical] = {}


def actuator_critical(req: Any) -> ActuatorCritical:
    """The control MARE's critical actuator probability: exact where known (:func:`known_critical`), else bracketed."""
    key = (req.system.A, req.B, req.W, req.U, req.actuator.table)
    hit = _ACTUATOR_CACHE.get(key)
    if hit is None:
        known = known_critical(req.system.A, req.B)
        hit = known if known is not None else _nu_c_bracket(req)
        if len(_ACTUATOR_CACHE) >= 8:
            _ACTUATOR_CACHE.clear()
        _ACTUATOR_CACHE[key] = hit
    return hit


def _nu_c_bracket(req: Any) -> ActuatorCritical:
    """``1 - 1/rho(A)^2 <= nu_c <= lambda_upper`` of the dual estimation problem ``(A', B', W, U)``.

    The control MARE on ``(A, B, W, U)`` is the estimation MARE of the dual
    system (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V),
    so the certified ``lambda_upper`` of :func:`kfio.bounds` on the dual
    (Sinopoli et al. 2004, Theorem 5, its LMI certificate re-checked exactly) is
    an upper end of the bracket; the lower end holds for any ``B`` (a lost packet
    applies no input).
    """
    from .._system import System
    from ..errors import AnalyzerError
    from ..model import parse_request
    from ..riccati_bounds import compute_bounds

    rho2, approx = largest_modulus(req.system.A)
    lower_exact = None if rho2 is None else (max(Fraction(0), 1 - 1 / rho2) if rho2 else Fraction(0))
    if lower_exact is not None:
        lower = float(lower_exact)
    else:
        rho = float(np.max(np.abs(np.linalg.eigvals(to_float(req.system.A)))))
        lower = max(0.0, 1.0 - 1.0 / rho**2) if rho > 0 else 0.0
    upper: float | None = None
    why = "bracket: 1 - 1/rho(A)^2 below, the certified upper bound of the dual estimation problem (A', B', W, U) above"
    try:
        dual = System(
            A=[[fraction_text(x) for x in row] for row in _transpose(req.system.A)],
            C=[[fraction_text(x) for x in row] for row in _transpose(req.B)],
            Q=[[fraction_text(x) for x in row] for row in req.W],
            R=[[fraction_text(x) for x in row] for row in req.U],
        )
        arrival = fraction_text(req.actuator.table[0])
        channel = {"model": "bernoulli", "arrival_probability": arrival}
        found = compute_bounds(parse_request({"system": dual.to_dict(), "channel": channel})).critical[0].upper
        upper = None if found.value is None else float(found.value)
        if upper is None:
            why = f"no certified upper bound: {found.reason}"
    except AnalyzerError as exc:
        why = f"no certified upper bound: {exc}"
    return ActuatorCritical(None, None, lower, upper, False, why, lower_exact=lower_exact)


def actuator_above(nu: Fraction, crit: ActuatorCritical) -> bool | None:
    """``nu > nu_c``: decided exactly when ``nu_c`` is known, by the bracket's ends otherwise (``None``: inside)."""
    if not crit.stabilizable:
        return False
    if crit.exact_value is not None:
        return nu > crit.exact_value
    if crit.enclosure is not None:  # an algebraic nu_c: irrational, so a fine enough enclosure excludes nu
        lo, hi = crit.enclosure
        return True if nu > hi else False if nu < lo else None
    if crit.lower_exact is not None and nu <= crit.lower_exact:
        return False
    if crit.lower_exact is None and crit.lower is not None and nu <= Fraction(crit.lower):
        return False
    if crit.upper is not None and nu >= Fraction(crit.upper):
        return True
    return None


def _solve(
    A: np.ndarray, C: np.ndarray, Q: np.ndarray, R: np.ndarray, p: float, equation: str
) -> tuple[Any, RiccatiSolve]:
    from ..riccati_bounds import mare_fixed_point

    fp = mare_fixed_point(A, C, Q, R, p)
    info = RiccatiSolve(
        equation,
        fp.residual,
        fp.newton_steps,
        fp.continuation_points,
        None if fp.matrix is None else float(np.trace(fp.matrix)),
    )
    return fp, info


def control_fixed_point(req: Any) -> tuple[Any, RiccatiSolve]:
    """``S`` of the control MARE at the actuator's ``nu``: the estimation MARE of ``(A', B', W, U)``."""
    A, B, _, _, _, W, U = lqg_floats(req)
    return _solve(A.T, B.T, W, U, float(req.actuator.table[0]), "control")


def estimation_fixed_point(req: Any) -> tuple[Any, RiccatiSolve]:
    """``P`` of the estimation MARE at the sensor's ``lambda`` (Sinopoli et al. 2004)."""
    A, _, C, Q, R, _, _ = lqg_floats(req)
    return _solve(A, C, Q, R, float(req.channel.table[0]), "estimation")


def optimal_reasons(req: Any, crit: ActuatorCritical) -> tuple[str, ...]:
    """Why no TCP-like controller has a bounded cost at the request's point (empty when one does)."""
    out = []
    stable, lam_c, lam_exact, note = optimal_sensor(req.system, req.channel)
    if not stable:
        lam = fraction_text(req.channel.table[0])
        if note is not None:
            out.append(note)
        elif lam_c is not None:
            shown = lam_exact if lam_exact is not None and len(lam_exact) <= 24 else f"{lam_c:.6g}"
            out.append(
                f"the sensor arrival probability {lam} is not above the optimal filter's critical value {shown} "
                f"({THEOREM_1}): no estimator keeps the error covariance bounded"
            )
        else:
            out.append(
                f"the optimal filter's error covariance is unbounded at sensor arrival probability {lam} ({THEOREM_1})"
            )
    nu = req.actuator.table[0]
    above = actuator_above(nu, crit)
    if not crit.stabilizable:
        out.append(crit.source)
    elif above is False:
        shown = crit.exact if crit.exact is not None and len(crit.exact) <= 24 else f"{crit.lower:.6g}"
        what = "its critical value" if crit.is_exact else "the lower end of its critical value's bracket"
        out.append(
            f"the actuator arrival probability {fraction_text(nu)} is not above {what} {shown} "
            f"({crit.source}): the control Riccati equation has no fixed point and no static feedback "
            "stabilizes the plant in mean square"
        )
    return tuple(out)


def with_lqg_gains(req: Any) -> Any:
    """``req`` (a :class:`kfio.loop._model.LoopRequest`) with the stationary TCP-like gains ``K`` and ``L``.

    ``K`` in the request's form (``filter`` unless the request says ``predictor``).
    Below the optimal critical values there are none: ``K`` and ``L`` stay empty
    and :func:`kfio.loop.analyze_loop` reports the verdict ``unstable`` without gains.
    """
    check_lqg_links(req)
    crit = actuator_critical(req)
    if optimal_reasons(req, crit):
        return dataclasses.replace(req, estimator=(), feedback=())
    S, _ = control_fixed_point(req)
    if S.matrix is None:
        raise NumericalFailure(
            "the control modified Riccati equation's fixed point was not found at this actuator arrival "
            f"probability, though it exists above {crit.lower if crit.upper is None else crit.upper:.6g} "
            f"({crit.source}): {S.reason}"
        )
    P, _ = estimation_fixed_point(req)
    if P.matrix is None:
        raise NumericalFailure(
            "the estimation modified Riccati equation's fixed point was not found at this sensor arrival "
            "probability, though the optimal time-varying filter is stable there (Rohr, Marelli and Fu 2014, "
            f"Theorem 1): no stationary estimator gain could be derived ({P.reason})"
        )
    A, B, C, _, R, _, U = lqg_floats(req)
    Sm, Pm = S.matrix, P.matrix
    L = np.linalg.solve(B.T @ Sm @ B + U, B.T @ Sm @ A)
    K_f = Pm @ C.T @ np.linalg.inv(C @ Pm @ C.T + R)
    K = K_f if req.form == "filter" else A @ K_f
    return dataclasses.replace(req, estimator=_exact(K), feedback=_exact(L))


def lqg_part(req: Any, budget: Any = None, with_bounds: bool = True) -> LqgPart:
    """The ``lqg`` block: the optimal controller's verdict, critical values and cost bounds, and the Riccati solves."""
    crit = actuator_critical(req)
    reasons = optimal_reasons(req, crit)
    _, lam_c, lam_exact, note = optimal_sensor(req.system, req.channel)
    gains = bool(req.K)
    control = estimation = None
    S_matrix = None
    if gains:
        S, control = control_fixed_point(req)
        S_matrix = S.matrix
        _, estimation = estimation_fixed_point(req)
    if reasons:
        bounds = unavailable("the optimal TCP-like cost is unbounded here: " + "; ".join(reasons))
    elif not with_bounds:
        bounds = unavailable("not computed: the time budget ran out")
    else:
        bounds = lqg_cost_bounds(req, S_matrix, budget)
    optimal = LqgOptimal(
        verdict="unstable" if reasons else "stable",
        reasons=reasons,
        critical_sensor=lam_c,
        critical_sensor_exact=lam_exact,
        sensor_note=note,
        actuator=crit,
        cost_bounds=bounds,
    )
    return LqgPart(optimal, req.form, gains, control, estimation)


def _short(value: float | None, exact: str | None) -> str | None:
    if value is None:
        return None
    return exact if exact is not None and len(exact) <= 12 else f"{value:.4g}"


def with_statement(
    part: LqgPart, sensor: tuple[float | None, str | None], actuator: tuple[float | None, str | None]
) -> LqgPart:
    """``part`` with its sentence: what the optimal controller needs, beside what the stationary gains need."""
    o = part.optimal
    a = o.actuator
    opt_s = _short(o.critical_sensor, o.critical_sensor_exact)
    opt_a = (
        _short(a.value, a.exact)
        if a.is_exact
        else (f"a value in [{a.lower:.4g}, {a.upper:.4g}]" if a.upper is not None and a.lower is not None else None)
    )
    if opt_s is None or opt_a is None:
        first = "no TCP-like controller stabilizes this plant at any arrival probability: " + "; ".join(o.reasons)
        return dataclasses.replace(part, optimal=dataclasses.replace(o, statement=first))
    first = f"the optimal TCP-like LQG needs sensor > {opt_s} and actuator > {opt_a}"
    if not part.gains:
        second = "no stationary gains exist here"
    else:
        ss, sa = _short(*sensor), _short(*actuator)
        second = f"these stationary gains ({part.form} form) need sensor > {ss or 'n/a'} and actuator > {sa or 'n/a'}"
    return dataclasses.replace(part, optimal=dataclasses.replace(o, statement=f"{first}; {second}"))


__all__ = [
    "PAPER",
    "LqgCostBounds",
    "actuator_above",
    "actuator_critical",
    "check_lqg_links",
    "control_fixed_point",
    "estimation_fixed_point",
    "lqg_part",
    "optimal_reasons",
    "optimal_sensor",
    "with_lqg_gains",
    "with_statement",
]
