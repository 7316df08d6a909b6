"""The requirements a check file may state, and how each is judged against a report.

Each requirement is read off the JSON report that ``kfio analyze|bounds|simulate
--json`` prints for the entry's plant and channel, so ``kfio check`` and the
single commands agree by construction:

=========================================  =========  ==================================================
key                                        command    holds when
=========================================  =========  ==================================================
``verdict``                                analyze    the exact verdict (Rohr, Marelli and Fu 2014,
                                                      Theorem 1) is the one named; for an entry naming
                                                      a trace, the verdict of the whole confidence
                                                      region of the fitted channel
``margin: m``                              analyze    the worst rate ``max_k |alpha_k|^2 sigma_k <= 1 - m``
``critical_arrival_probability_at_most``   analyze    the exact critical arrival probability ``<= v``
``tail_exponent_above: k``                 analyze    the tail exponent ``kappa > k`` (Mo and Sinopoli
                                                      2012: ``P(trace P > M) ~ M^-kappa``; the moment of
                                                      order ``r`` is finite iff ``kappa > r``)
``trace_V_bar_at_most: T``                 bounds     ``trace(V_bar) <= T``, ``V_bar`` the upper end of
                                                      the certified bracket of the MARE fixed point
                                                      (Sinopoli et al. 2004, Theorem 4)
``outage: {threshold: M, epsilon: e}``     simulate   the upper end of the Wilson 95% interval of the
                                                      stationary ``P(trace P > M)`` is ``<= e``
                                                      (Monte Carlo evidence, not a certificate)
``loop_verdict``                           loop       the loop's exact mean-square verdict (Costa,
                                                      Fragoso and Marques 2005, Thm 3.9) is the one named
``loop_cost_at_most: J``                   loop       the exact stationary cost ``lim E[x'Wx + a'Ua] <= J``
                                                      (unbounded: fails)
``critical_sensor_arrival_probability_     loop       the loop's exact critical sensor arrival
at_most: v``                                          probability ``<= v`` (the actuator at its value)
``critical_actuator_arrival_probability_   loop       the loop's exact critical actuator arrival
at_most: v``                                          probability ``<= v`` (the sensor at its value)
=========================================  =========  ==================================================

A link whose stable set is an interval ``(a, b)`` that does not reach 1 (a
UDP-like loop: the estimator assumes the link's arrival rate, so a better link
can destabilize it) has no critical value; the stable interval holding the
request's point stands for it, and ``critical <= v`` holds iff ``a <= v <= b``.

The ``loop`` requirements are judged on the report of ``kfio loop --json``
for the entry's loop request (Schenato, Sinopoli, Franceschetti, Poolla and
Sastry 2007, Sec. II, for the model).

Comparisons are exact where kfio has the exact value (a rational worst rate,
a rational critical probability) and otherwise in floating point; a float
within a relative ``1e-9`` of the limit is not decided (status ``error``)
rather than guessed.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Mapping

from ..errors import InvalidInput
from ..model import fraction_text, json_pointer, parse_integer, parse_number

VERDICTS = ("stable", "unstable", "boundary")

#: Requirement key -> the command whose report judges it.
COMMAND_OF = {
    "verdict": "analyze",
    "margin": "analyze",
    "critical_arrival_probability_at_most": "analyze",
    "tail_exponent_above": "analyze",
    "trace_V_bar_at_most": "bounds",
    "outage": "simulate",
    "loop_verdict": "loop",
    "loop_cost_at_most": "loop",
    "critical_sensor_arrival_probability_at_most": "loop",
    "critical_actuator_arrival_probability_at_most": "loop",
}

#: The loop report's field judged by each ``*_at_most`` loop requirement.
LOOP_LIMITS = {
    "loop_cost_at_most": "cost",
    "critical_sensor_arrival_probability_at_most": "critical_sensor_arrival_probability",
    "critical_actuator_arrival_probability_at_most": "critical_actuator_arrival_probability",
}

#: Keys of an ``outage`` requirement (the last three set the Monte Carlo run).
OUTAGE_KEYS = ("threshold", "epsilon", "trajectories", "steps", "seed")

#: Relative distance to a limit below which a floating-point comparison is not trusted.
FLOAT_TIE = 1e-9


@dataclass(frozen=True)
class Requirement:
    """One requirement of one check entry: its key and its exact limit."""

    key: str
    value: Any  # str (verdict), Fraction, or a dict for outage
    command: str

    @property
    def required_exact(self) -> str | None:
        """The exact limit as text (``'1/2'``) where the requirement is a number, else ``None``."""
        return fraction_text(self.value) if isinstance(self.value, Fraction) else None

    @property
    def required(self) -> str:
        """The requirement as text, e.g. ``'<= 1/2'``."""
        v = self.value
        if self.key in ("verdict", "loop_verdict"):
            return f"= {v}"
        if self.key == "margin":
            return f"worst rate <= {fraction_text(1 - v)} (margin {fraction_text(v)})"
        if self.key == "tail_exponent_above":
            return f"> {fraction_text(v)}"
        if self.key == "outage":
            return f"P(trace P > {fraction_text(v['threshold'])}) <= {fraction_text(v['epsilon'])}"
        return f"<= {fraction_text(v)}"


@dataclass(frozen=True)
class Judgement:
    """How one requirement fared: ``status`` is ``pass``, ``fail`` or ``error``."""

    status: str
    measured: str
    detail: str
    #: The measured quantity's exact text (a fraction or an algebraic number) and its float, where kfio has them.
    exact: str | None = None
    approx: float | None = None


def parse_requirements(obj: Any, where: str) -> tuple[Requirement, ...]:
    """Validate the ``requirements`` object of a check entry (``where`` is its JSON pointer)."""
    if not isinstance(obj, Mapping) or not obj:
        raise InvalidInput(where, f"expected a non-empty object with keys among {sorted(COMMAND_OF)}")
    out = []
    for key, raw in obj.items():
        field = where + json_pointer((key,))
        if key not in COMMAND_OF:
            raise InvalidInput(field, f"unknown requirement; expected one of {sorted(COMMAND_OF)}")
        out.append(Requirement(key, _parse_value(key, raw, field), COMMAND_OF[key]))
    return tuple(out)


def _parse_value(key: str, raw: Any, field: str) -> Any:
    if key in ("verdict", "loop_verdict"):
        if raw not in VERDICTS:
            raise InvalidInput(field, f"expected one of {list(VERDICTS)}")
        return raw
    if key == "outage":
        if not isinstance(raw, Mapping):
            raise InvalidInput(
                field, f"expected an object with keys threshold, epsilon (and optionally {OUTAGE_KEYS[2:]})"
            )
        unknown = sorted(set(raw) - set(OUTAGE_KEYS))
        if unknown:
            raise InvalidInput(f"{field}/{unknown[0]}", f"unknown key; an outage requirement has {list(OUTAGE_KEYS)}")
        for need in ("threshold", "epsilon"):
            if need not in raw:
                raise InvalidInput(f"{field}/{need}", "required")
        value: dict[str, Any] = {
            "threshold": parse_number(raw["threshold"], f"{field}/threshold"),
            "epsilon": parse_number(raw["epsilon"], f"{field}/epsilon"),
        }
        if value["threshold"] <= 0:
            raise InvalidInput(f"{field}/threshold", "the threshold M of P(trace P > M) must be positive")
        if not 0 < value["epsilon"] < 1:
            raise InvalidInput(f"{field}/epsilon", "epsilon must be in (0, 1)")
        for name, lo in (("trajectories", 2), ("steps", 1), ("seed", 0)):
            if name in raw:
                value[name] = parse_integer(raw[name], f"{field}/{name}", lo, name=name)
        return value
    number = parse_number(raw, field)
    if key == "margin" and not 0 <= number < 1:
        raise InvalidInput(field, "a margin m asks worst rate <= 1 - m; m must be in [0, 1)")
    if key.startswith("critical_") and not 0 <= number <= 1:
        raise InvalidInput(field, "a probability must be in [0, 1]")
    if key in ("trace_V_bar_at_most", "tail_exponent_above", "loop_cost_at_most") and number <= 0:
        raise InvalidInput(field, "must be positive")
    return number


def _compare(measured: float, exact: Fraction | None, limit: Fraction, strict: bool, upper: bool) -> bool | None:
    """``measured <= limit`` (``upper``) or ``measured > limit``; ``None`` if a float is too close to tell."""
    if exact is not None:
        a, b = exact, limit
    else:
        if abs(measured - float(limit)) <= FLOAT_TIE * max(1.0, abs(float(limit))):
            return None
        a, b = Fraction(measured), limit
    if upper:
        return a < b if strict else a <= b
    return a > b if strict else a >= b


def _exact_or_none(text: Any) -> Fraction | None:
    if not isinstance(text, str):
        return None
    try:
        return parse_number(text, "/")
    except InvalidInput:
        return None


def _verdict(ok: bool | None, measured: str, detail: str, exact: Any = None, approx: Any = None) -> Judgement:
    text = exact if isinstance(exact, str) else None
    value = float(approx) if isinstance(approx, (int, float)) else None
    if ok is None:
        return Judgement(
            "error", measured, "too close to the limit to decide in floating point; " + detail, text, value
        )
    return Judgement("pass" if ok else "fail", measured, detail, text, value)


def judge(req: Requirement, payload: Mapping[str, Any]) -> Judgement:
    """Judge ``req`` on a worker's payload: ``{"report": <report JSON>, ...exact extras}``."""
    report = payload["report"]
    if req.key == "verdict" and report.get("fit"):  # an entry naming a trace: the whole confidence region
        fit = report["fit"]
        level = f"{fit['level'] * 100:g}%"
        needed = "" if fit["samples_needed"] is None else f"; about {fit['samples_needed']} packets would decide"
        return Judgement(
            "pass" if fit["verdict"] == req.value else "fail",
            f"{fit['verdict']} at {level} (estimate: {report.get('verdict')})",
            f"verdict of the whole {level} confidence region of the {fit['model']} channel fitted to "
            f"{fit['samples']} packets{needed}",
        )
    if req.key == "verdict":
        verdict = report.get("verdict")
        return Judgement(
            "pass" if verdict == req.value else "fail", str(verdict), f"exact verdict ({report.get('theorem')})"
        )
    if req.key == "margin":
        rate, exact = payload.get("worst_rate"), _exact_or_none(payload.get("worst_rate_exact"))
        if rate is None:
            return Judgement("pass", "no unstable block", "no block has |alpha| >= 1: every rate is 0")
        measured = fraction_text(exact) if exact is not None else f"{rate:.6g}"
        basis = "exact" if exact is not None else "floating point"
        return _verdict(
            _compare(rate, exact, 1 - req.value, False, True),
            f"worst rate {measured}",
            f"worst |alpha_k|^2 sigma_k ({basis})",
            payload.get("worst_rate_exact"),
            rate,
        )
    if req.key == "critical_arrival_probability_at_most":
        value = report.get("critical_arrival_probability")
        text = report.get("critical_arrival_probability_exact")
        if value is None:
            return Judgement("error", "none", "kfio gives a critical arrival probability for one Bernoulli packet only")
        exact = _exact_or_none(text)
        return _verdict(
            _compare(value, exact, req.value, False, True),
            str(text or value),
            "exact critical arrival probability",
            text,
            value,
        )
    if req.key == "tail_exponent_above":
        tail = report.get("tail") or {}
        kappa = tail.get("kappa")
        if kappa is None:
            return Judgement("error", "none", "no tail exponent in the report (the filter is not stable)")
        measured = f"{kappa:.6g}" + (f" = {tail['kappa_exact']}" if tail.get("kappa_exact") else "")
        return _verdict(
            _compare(kappa, None, req.value, True, False), measured, tail.get("statement") or "tail exponent"
        )
    if req.key == "trace_V_bar_at_most":
        v_bar = (report.get("covariance") or {}).get("V_bar") or {}
        if not v_bar.get("exists"):
            return Judgement("fail", "V_bar does not exist", v_bar.get("reason") or "the MARE has no fixed point here")
        trace = v_bar["trace"]
        detail = "upper end of the certified bracket of V_bar (Sinopoli et al. 2004, Theorem 4)"
        return _verdict(_compare(trace, None, req.value, False, True), f"{trace:.6g}", detail)
    if req.key == "loop_verdict":
        verdict = report.get("verdict")
        return Judgement(
            "pass" if verdict == req.value else "fail", str(verdict), f"exact loop verdict ({report.get('theorem')})"
        )
    if req.key in LOOP_LIMITS:
        return _judge_loop_limit(req, report, payload.get("link_points") or {})
    if req.key == "outage":
        stationary = report.get("stationary") or {}
        rows = stationary.get("outage") or []
        if not rows:
            return Judgement("error", "none", "the simulation gave no stationary outage estimate")
        row = rows[0]
        lo, hi = row["ci95"]
        measured = f"{row['probability']:.4g} (95% CI [{lo:.4g}, {hi:.4g}], {stationary.get('samples')} samples)"
        ok = Fraction(hi) <= req.value["epsilon"]
        why = "Monte Carlo evidence: the upper end of the Wilson 95% interval must be <= epsilon"
        return Judgement("pass" if ok else "fail", measured, why)
    raise AssertionError(req.key)  # pragma: no cover - parse_requirements admits only the keys above


def _judge_loop_limit(req: Requirement, report: Mapping[str, Any], points: Mapping[str, str]) -> Judgement:
    """``cost``, or a link's critical arrival probability, of a loop report at most the limit (exactly).

    ``points`` holds the request's value of each link parameter (by JSON pointer): a link whose
    stable set does not reach 1 is judged on the stable interval that holds the request's point.
    """
    field = LOOP_LIMITS[req.key]
    value, text = report.get(field), report.get(f"{field}_exact")
    if value is None:
        if field == "cost":
            return Judgement("fail", "unbounded", "the loop is not mean-square stable: its stationary cost is infinite")
        link = "actuator" if "actuator" in field else "sensor"
        found = [
            c for c in report.get("critical_values") or [] if (c.get("link") == "actuator") == (link == "actuator")
        ]
        note = found[0].get("note", "") if found else f"no critical {link} arrival probability in the report"
        if note.startswith("no value"):  # no value near 1 stabilizes the loop: a stable interval may lie lower
            return _judge_stable_interval(req, found[0], points.get(found[0].get("parameter", "")))
        return Judgement("error", "none", note)
    exact = _exact_or_none(text)
    what = "exact stationary cost" if field == "cost" else f"exact critical {field.split('_')[1]} arrival probability"
    measured = str(text) if exact is not None and len(str(text)) <= 40 else f"{value:.6g}"
    return _verdict(_compare(value, exact, req.value, False, True), measured, what, text, value)


def _judge_stable_interval(req: Requirement, critical: Mapping[str, Any], point: str | None) -> Judgement:
    """A link whose stable set is an interval ``(a, b)`` with ``b < 1`` (a UDP-like estimator assumes the link's rate).

    The interval that holds the request's point stands for the critical value: its left end ``a``
    is the least arrival probability the loop tolerates, and a better link than ``b`` destabilizes
    it.  The requirement ``critical <= v`` holds iff ``v`` lies in ``[a, b]``: the loop is then
    stable with the link anywhere between ``v`` and the request's point.  No stable interval at the
    request's point: fail.
    """
    stable = [(i["from"], i["to"]) for i in critical.get("intervals") or [] if i.get("verdict") == "stable"]
    spans = ", ".join(f"({a:.6g}, {b:.6g})" for a, b in stable)
    at = None if point is None else _exact_or_none(point)
    home = [(a, b) for a, b in stable if at is not None and a < at < b]
    if not home:
        where = "no arrival probability of this link stabilizes the loop" if not stable else f"stable only in {spans}"
        return Judgement("fail", "none", f"the loop is not stable at the request's point {point}; {where}")
    a, b = home[0]
    above, below = _compare(a, None, req.value, False, True), _compare(b, None, req.value, False, False)
    measured = f"stable interval ({a:.6g}, {b:.6g})"
    detail = (
        f"no critical value near 1: the loop is stable for this link only in ({a:.6g}, {b:.6g}), which holds the "
        f"request's point {point} (the estimator's assumed arrival rate is fixed); the limit must lie in it"
    )
    if above is None or below is None:
        return _verdict(None, measured, detail)
    return Judgement("pass" if above and below else "fail", measured, detail)


__all__ = ["COMMAND_OF", "OUTAGE_KEYS", "Judgement", "Requirement", "judge", "parse_requirements"]
