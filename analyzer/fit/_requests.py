"""Requests whose channel is a measured trace, and their verdicts at a stated confidence.

A request (``kfio analyze``, ``kfio loop``) may give a link as
``{"model": "trace", "arrivals": "0110...", "level": 0.95}``: the trace is
fitted (:func:`kfio.fit.fit`), the fitted channel (exact) takes the trace's
place, and the report gains a ``fit`` block with the verdict of the whole
confidence region (:mod:`kfio.fit._confidence`).  The headline stays the exact
verdict of the point estimate.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from fractions import Fraction
from typing import Any

from .._budget import Budget
from ..errors import AssumptionViolation, InvalidInput
from ..model import DEFAULT_LIMITS, Limits, Request, check_keys, load_json, parse_markov_channel, parse_request
from ._confidence import ConfidenceVerdict, confidence_verdict
from ._fit import DEFAULT_LEVEL, FitReport, fit_trace, parse_level
from ._trace import Trace, as_trace

_TRACE_KEYS = {"model", "arrivals", "level", "max_order"}

#: How ``kfio analyze`` decides the region, by model.
ANALYZE_METHOD = {
    "bernoulli": "exact: the stable set is lambda > lambda_c (Rohr, Marelli and Fu 2014, Corollary 2), so kfio's "
    "exact verdict at the two ends of the interval decides it",
    "gilbert_elliott": "kfio's exact verdict (Rohr, Marelli and Fu 2014, Theorem 1) at every corner of the (p, q) box; "
    "exact where the stable set is monotone over the box (the worst corner: highest failure rate, lowest recovery "
    "rate), a stated check otherwise",
    "markov": "kfio's exact verdict (Rohr, Marelli and Fu 2014, Theorem 1) at the extreme corners of the box and at "
    "every other corner up to 16 (a seeded sample of 16 beyond); exact where the stable set is monotone over the box, "
    "a stated check otherwise",
}
LOOP_METHOD = {
    "bernoulli": "exact: kfio's exact loop verdict (Costa, Fragoso and Marques 2005, Thm 3.9) at both ends of the "
    "interval, and no root of det(I - T(lambda)), where the verdict may change, inside it",
    "gilbert_elliott": ANALYZE_METHOD["gilbert_elliott"].replace(
        "Rohr, Marelli and Fu 2014, Theorem 1", "the loop's, Costa, Fragoso and Marques 2005, Thm 3.9"
    ),
    "markov": ANALYZE_METHOD["markov"].replace(
        "Rohr, Marelli and Fu 2014, Theorem 1", "the loop's, Costa, Fragoso and Marques 2005, Thm 3.9"
    ),
}


def _prefixed(exc: InvalidInput, link: str) -> InvalidInput:
    field = exc.field if exc.field.startswith("/") else "/" + exc.field
    return type(exc)(link + (field if field != "/" else ""), exc.rule)


_FIT_KEYS = {"arrivals", "level", "model", "order", "max_order"}


def fit_request(tree: Any) -> FitReport:
    """The fit of a ``POST /v1/fit`` body: ``{"arrivals": "0110..." or [0, 1, ...], "level": 0.95}``.

    Optional ``model`` (``bernoulli``, ``gilbert_elliott``, ``markov`` with
    ``order``) forces a model; ``max_order`` bounds the Markov orders tried.
    """
    check_keys(tree, "", _FIT_KEYS, {"arrivals"})
    model = tree.get("model")
    if model is not None and not isinstance(model, str):
        raise InvalidInput("/model", "expected one of bernoulli, gilbert_elliott, markov")
    level = parse_level(tree["level"]) if "level" in tree else DEFAULT_LEVEL
    return fit_trace(
        as_trace(tree["arrivals"]), level=level, model=model, order=tree.get("order"), max_order=tree.get("max_order")
    )


def fit_link(obj: Any, link: str) -> FitReport:
    """Fit the trace channel object ``obj`` found at ``link`` (errors name ``link/...``)."""
    check_keys(obj, link, _TRACE_KEYS, {"model", "arrivals"})
    try:
        trace = as_trace(obj["arrivals"])
        level = parse_level(obj["level"]) if "level" in obj else DEFAULT_LEVEL
        return fit_trace(trace, level=level, max_order=obj.get("max_order"))
    except InvalidInput as exc:
        raise _prefixed(exc, link) from None


def _refuse_edge(found: FitReport, where: str) -> None:
    """Refuse a fitted channel with a conditional arrival probability of 0 or 1 (outside Assumption 1)."""
    edge = [name for name, x in found.estimates.items() if x in (0, 1)]
    if edge:
        raise AssumptionViolation(
            where,
            f"the {found.model} model fitted to the trace has {edge[0]} = {found.parameters[edge[0]]}: "
            "Assumption 1 of Rohr, Marelli and Fu 2014 requires every conditional arrival probability to "
            "lie strictly between 0 and 1, so no verdict is given; a longer trace, or one with both outcomes "
            "after every history, is needed",
        )


def resolve_traces(tree: Any, links: tuple[str, ...] = ("/channel",)) -> tuple[Any, dict[str, FitReport]]:
    """``tree`` with every trace channel at ``links`` replaced by its fitted channel, and the fits by link."""
    if not isinstance(tree, dict):
        return tree, {}
    fits: dict[str, FitReport] = {}
    out = dict(tree)
    for link in links:
        key = link.lstrip("/")
        obj = tree.get(key)
        if isinstance(obj, Mapping) and obj.get("model") == "trace":
            found = fit_link(obj, link)
            _refuse_edge(found, f"{link}/arrivals")
            fits[link] = found
            out[key] = found.channel
    return out, fits


def load_trace_request(text: str | bytes, limits: Limits = DEFAULT_LIMITS) -> tuple[Request, dict[str, FitReport]]:
    """:func:`kfio.load_request`, with a trace channel fitted first (module docstring)."""
    tree, fits = resolve_traces(load_json(text))
    return parse_request(tree, limits), fits


def load_trace_loop_request(text: str | bytes, limits: Limits = DEFAULT_LIMITS) -> tuple[Any, dict[str, FitReport]]:
    """:func:`kfio.loop.load_loop_request`, with trace channels (sensor or actuator) fitted first."""
    from ..loop import parse_loop_request

    tree, fits = resolve_traces(load_json(text), ("/channel", "/actuator_channel"))
    return parse_loop_request(tree, limits), fits


def with_trace(request: Request, trace: Trace | Any, level: Any = None) -> tuple[Request, FitReport]:
    """``request`` with its channel replaced by the model fitted to ``trace`` (``kfio analyze --trace``)."""
    from ..model import PerSensorChannel

    if isinstance(request.channel, PerSensorChannel):
        raise InvalidInput("--trace", "a trace gives one packet's channel; this request has one channel per sensor")
    lvl = DEFAULT_LEVEL if level is None else level if isinstance(level, Fraction) else parse_level(level, "--level")
    found = fit_trace(as_trace(trace), level=lvl)
    _refuse_edge(found, "--trace")
    channel = parse_markov_channel(found.channel)
    return dataclasses.replace(request, channel=channel), found


def analyze_at_confidence(
    request: Request, found: FitReport, point: str, budget: Budget | None = None
) -> ConfidenceVerdict:
    """The ``fit`` block of ``kfio analyze``: the exact verdict (Rohr, Marelli and Fu 2014, Theorem 1) of the whole box.

    ``request`` carries the fitted channel; ``point`` is its exact verdict.
    The FMO blocks of the plant are computed once and every corner reuses them.
    """
    from ..stability import analyze
    from ..structure import fmo_blocks

    work = budget if budget is not None else Budget(seconds=request.time_budget_s or 120.0)
    fmo = fmo_blocks(request.system, work)
    memo: dict[Any, Any] = {}
    plain = dataclasses.replace(request, options={})

    def evaluate(channel: dict[str, Any]) -> str:
        req = dataclasses.replace(plain, channel=parse_markov_channel(channel))
        return str(analyze(req, work, fmo=fmo, memo=memo, tail="kappa").verdict)

    return confidence_verdict(found, evaluate, point, method=ANALYZE_METHOD[found.model])


def _roots(report: Mapping[str, Any], link: str) -> tuple[float, ...] | None:
    """The points of ``(0, 1)`` where the loop's verdict may change along ``link``'s one parameter."""
    for c in report.get("critical_values") or ():
        if c.get("link") == link or str(c.get("parameter", "")).startswith(link):
            return tuple(float(iv["to"]) for iv in c.get("intervals", [])[:-1])
    return None


def loop_at_confidence(
    request: Any, found: FitReport, link: str, report: Mapping[str, Any], budget: Budget | None = None
) -> ConfidenceVerdict:
    """The ``fit`` block of ``kfio loop``: the exact loop verdict (Costa, Fragoso and Marques 2005, Thm 3.9) of the box.

    ``request`` is the loop request with the fitted channel at ``link``
    (``/channel`` or ``/actuator_channel``) and ``report`` its JSON report.
    """
    from ..loop import decide, loop_mjls

    def evaluate(channel: dict[str, Any]) -> str:
        where = link if link == "/actuator_channel" else "/channel"
        ch = parse_markov_channel(channel, where=where)
        return str(decide(loop_mjls(request, {where: ch}), budget).verdict)

    roots = _roots(report, link) if found.model == "bernoulli" else None
    if found.model == "bernoulli" and roots is None:
        roots = ()
    return confidence_verdict(
        found, evaluate, str(report["verdict"]), link=link, roots=roots, method=LOOP_METHOD[found.model]
    )


__all__ = [
    "ANALYZE_METHOD",
    "LOOP_METHOD",
    "analyze_at_confidence",
    "fit_link",
    "fit_request",
    "load_trace_loop_request",
    "load_trace_request",
    "loop_at_confidence",
    "resolve_traces",
    "with_trace",
]
