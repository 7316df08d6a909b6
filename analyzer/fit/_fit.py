"""``kfio fit``: a channel model for a packet trace, with exact estimates, scores, intervals and a fit check.

The candidates are the channels kfio analyzes: Bernoulli (order 0), the
Gilbert-Elliott arrival chain (order 1; Gilbert 1960, Elliott 1963) and
Markov chains of order ``2 .. max_order`` (Yajnik, Moon, Kurose and Towsley
1999).  Each is fitted by maximum likelihood from its transition counts
(exact rationals, :mod:`kfio.fit._estimate`) and scored by the Bayesian
information criterion ``BIC = -2 log L + d log n`` (Schwarz 1978) on the
positions every candidate can score; the smallest BIC wins.  The chosen
model's loss and arrival runs are then checked against its run-length law
(:mod:`kfio.fit._runs`), and every parameter gets an exact binomial interval,
joint by Bonferroni (:mod:`kfio.fit._intervals`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from typing import TYPE_CHECKING, Any, ClassVar

from .._budget import Budget
from .._numbers import number_text
from .._reporting import Report
from ..errors import InvalidInput
from ..model import budget_seconds, fraction_text, parse_number
from ._estimate import Candidate, candidate, history_key, model_name
from ._intervals import bonferroni_level, clopper_pearson, interval_method
from ._runs import run_test
from ._trace import Trace, as_trace

if TYPE_CHECKING:
    from .._typing import BudgetLike

#: Default confidence level of the intervals and of the verdict.
DEFAULT_LEVEL = Fraction(95, 100)
#: Default largest Markov order tried, and the largest one allowed.
DEFAULT_MAX_ORDER = 4
MAX_ORDER = 8
#: A run-length test with a p-value below this says the model does not fit.
FIT_P_VALUE = 0.01
CRITERION = (
    "BIC = -2 log L + d log n (Schwarz 1978), d = 2^order free probabilities, on the n positions after the first "
    "max_order packets (the same for every candidate); the smallest wins"
)
_MODELS = ("bernoulli", "gilbert_elliott", "markov")


def parse_level(value: Any, where: str = "/level") -> Fraction:
    """The confidence level as an exact rational in ``(0, 1)`` (from its decimal text)."""
    if isinstance(value, bool):
        raise InvalidInput(where, "the confidence level is a number in (0, 1), e.g. 0.95")
    level = parse_number(value, where)
    if not 0 < level < 1:
        raise InvalidInput(where, f"the confidence level must lie strictly between 0 and 1, e.g. 0.95; got {value}")
    return level


def _order_of(model: str | None, order: Any, max_order: Any) -> tuple[int | None, int]:
    for name, value in (("/order", order), ("/max_order", max_order)):
        if value is not None and (isinstance(value, bool) or not isinstance(value, int)):
            raise InvalidInput(name, f"expected an integer; got {value!r:.40}")
    top = DEFAULT_MAX_ORDER if max_order is None else max_order
    if not 0 <= top <= MAX_ORDER:
        raise InvalidInput("/max_order", f"max_order must be an integer in 0..{MAX_ORDER}")
    if model is None:
        if order is not None:
            raise InvalidInput("/order", 'order needs "model": "markov"')
        return None, top
    if model not in _MODELS:
        raise InvalidInput("/model", f"unknown model {model!r:.40}; expected one of {', '.join(_MODELS)}")
    if model == "markov":
        if order is None:
            raise InvalidInput("/order", f"a Markov model needs its order, an integer in 2..{MAX_ORDER}")
        if not 2 <= order <= MAX_ORDER:
            raise InvalidInput("/order", f"the Markov order must be an integer in 2..{MAX_ORDER}")
        return order, max(top, order)
    if order is not None:
        raise InvalidInput("/order", f'order is for "model": "markov" only; {model} has order {_MODELS.index(model)}')
    forced = _MODELS.index(model)
    return forced, max(top, forced)


@dataclass(frozen=True, repr=False)
class FitReport(Report):
    """The fitted channel of one trace: ``to_dict()`` is ``kfio fit --json``.

    Attributes
    ----------
    model, order:
        The chosen model (``bernoulli``, ``gilbert_elliott`` or ``markov``) and its order.
    parameters:
        Name to exact rational text: ``arrival_probability``;
        ``failure_rate`` and ``recovery_rate``; or ``arrival_probability/<history>``.
    intervals:
        Name to ``[lower, upper]``: the box that holds every parameter at once
        with probability at least ``level`` (Bonferroni).
    marginal_intervals:
        Each parameter's own interval at ``level``.
    trials:
        Name to ``(successes, trials)`` of its binomial estimate.
    channel:
        The channel object of a request, exact.
    """

    _repr_fields: ClassVar[tuple[str, ...]] = ("model", "order", "parameters", "samples")

    model: str
    order: int
    parameters: dict[str, str]
    intervals: dict[str, tuple[float, float]]
    marginal_intervals: dict[str, tuple[float, float]]
    level: Fraction
    interval_method: str
    samples: int
    counts: dict[str, Any]
    criterion: str
    scores: tuple[dict[str, Any], ...]
    goodness_of_fit: dict[str, Any]
    channel: dict[str, Any]
    trials: dict[str, tuple[int, int]]
    estimates: dict[str, Fraction]
    source: str = "arrivals"
    sequence: dict[str, Any] | None = None
    warnings: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    forced: bool = field(default=False)

    def joint_intervals(self, level: Fraction, parameters: int | None = None) -> dict[str, tuple[float, float]]:
        """The Bonferroni box at ``level`` over ``parameters`` intervals in all (default: this model's)."""
        each = float(bonferroni_level(level, parameters or len(self.trials)))
        return {name: clopper_pearson(k, n, each) for name, (k, n) in self.trials.items()}

    def summary(self) -> str:
        """A few lines for the terminal: the model, its parameters with intervals, the check."""
        head = f"model: {self.model}" + (f" (order {self.order})" if self.model == "markov" else "")
        how = "forced" if self.forced else "chosen by BIC"
        lines = [f"{head}  ({how}; {self.samples} packets from {self.source})"]
        for name, text in self.parameters.items():
            lo, hi = self.intervals[name]
            lines.append(f"  {name} = {number_text(text, float(self.estimates[name]))}  [{lo:.6g}, {hi:.6g}]")
        lines.append(f"intervals: {self.interval_method}")
        for s in self.scores:
            bic = "n/a (some history never occurs)" if s["bic"] is None else f"{s['bic']:.6g}"
            lines.append(f"  BIC {s['model']}{'' if s['model'] != 'markov' else ' order ' + str(s['order'])}: {bic}")
        runs = self.goodness_of_fit.get("loss_runs") or {}
        if runs.get("p_value") is not None:
            lines.append(
                f"loss runs: {runs['runs']} complete, mean {runs['mean_length']:.4g} (model {runs['model_mean_length']:.4g}), "
                f"chi-square p = {runs['p_value']:.3g}"
            )
        if self.sequence is not None:
            q = self.sequence
            lines.append(
                f"sequence numbers: {q['received']} received, {q['lost']} lost, {q['duplicates']} duplicates, "
                f"{q['reordered']} reordered, {q['wraps']} wraps (modulus {q['modulus']}, window {q['window']})"
            )
        lines.append(f"channel: {_channel_text(self.channel)}")
        lines += [f"note: {n}" for n in self.notes]
        lines += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines)


def _channel_text(channel: dict[str, Any]) -> str:
    import json

    return json.dumps(channel)


def _parameters(c: Candidate) -> tuple[dict[str, Fraction], dict[str, tuple[int, int]]]:
    """Name -> estimate, and name -> (successes, trials) of its binomial count."""
    counts = c.counts.tolist()
    if c.order == 0:
        n0, n1 = counts[0]
        return {"arrival_probability": Fraction(n1, n0 + n1)}, {"arrival_probability": (n1, n0 + n1)}
    if c.order == 1:
        (l0, l1), (a0, a1) = counts  # history 0: after a loss; history 1: after an arrival
        return (
            {"failure_rate": Fraction(a0, a0 + a1), "recovery_rate": Fraction(l1, l0 + l1)},
            {"failure_rate": (a0, a0 + a1), "recovery_rate": (l1, l0 + l1)},
        )
    est, trials = {}, {}
    for h, (n0, n1) in enumerate(counts):
        name = f"arrival_probability/{history_key(h, c.order)}"
        est[name] = Fraction(n1, n0 + n1)
        trials[name] = (n1, n0 + n1)
    return est, trials


def channel_of(model: str, order: int, estimates: dict[str, Fraction]) -> dict[str, Any]:
    """The request's channel object of a fitted model, exact rational text."""
    if model != "markov":
        return {"model": model, **{k: fraction_text(v) for k, v in estimates.items()}}
    prefix = "arrival_probability/"
    return {
        "model": "markov",
        "order": order,
        "arrival_probability": {k.removeprefix(prefix): fraction_text(v) for k, v in estimates.items()},
    }


def _too_short(c: Candidate, n: int) -> InvalidInput:
    missing = [history_key(h, c.order) for h, x in enumerate(c.table) if x is None]
    shown = ", ".join(repr(m) for m in missing[:4]) + (" ..." if len(missing) > 4 else "")
    name = model_name(c.order) + (f" order {c.order}" if c.order >= 2 else "")
    return InvalidInput(
        "/arrivals",
        f"the trace is too short for a {name} model: every history of {c.order} packets must be followed by a "
        f"packet at least once, which needs at least {(1 << c.order) + c.order} packets; in these {n}, "
        f"these histories never are: {shown}",
    )


def _counts(arrivals: Any, chosen: Candidate) -> dict[str, Any]:
    from ._estimate import transition_counts

    n1 = int(arrivals.sum())
    t = transition_counts(arrivals, 1).tolist()
    out: dict[str, Any] = {
        "samples": int(arrivals.size),
        "arrived": n1,
        "lost": int(arrivals.size) - n1,
        "transitions": {"0->0": t[0][0], "0->1": t[0][1], "1->0": t[1][0], "1->1": t[1][1]},
    }
    if chosen.order >= 2:
        out["histories"] = {
            history_key(h, chosen.order): {"0": n0, "1": n1} for h, (n0, n1) in enumerate(chosen.counts.tolist())
        }
    return out


def _goodness(arrivals: Any, cands: list[Candidate], chosen: Candidate) -> tuple[dict[str, Any], list[str]]:
    def table(c: Candidate) -> list[float]:
        return [float(x) if x is not None else 0.5 for x in c.table]

    def fitted(c: Candidate) -> int:
        return 1 if c.order <= 1 else 1 << (c.order - 1)

    loss = run_test(arrivals, table(chosen), 0, fitted(chosen))
    arrival = run_test(arrivals, table(chosen), 1, fitted(chosen))
    fits = None if loss.p_value is None else loss.p_value >= FIT_P_VALUE
    warnings = []
    if fits is False:
        others = [
            c
            for c in cands
            if c is not chosen
            and c.complete
            and (run_test(arrivals, table(c), 0, fitted(c)).p_value or 0) >= FIT_P_VALUE
        ]
        which = (
            "; the loss runs of " + ", ".join(_label(c) for c in others) + " do fit"
            if others
            else "; no candidate model fits them: the channel may have hidden state (a Gilbert-Elliott channel "
            "with losses in both states, Elliott 1963) or change over the trace"
        )
        warnings.append(
            f"the loss runs of the trace do not follow the {_label(chosen)} model (chi-square p = {loss.p_value:.3g} "
            f"< {FIT_P_VALUE}){which}; a verdict from this model may be wrong"
        )
    return (
        {
            "test": "Pearson chi-square on binned lengths of complete loss and arrival runs against the chosen "
            f"model's run-length law; the model is said not to fit when the loss-run p-value is below {FIT_P_VALUE}",
            "fits": fits,
            "loss_runs": loss.as_dict(),
            "arrival_runs": arrival.as_dict(),
        },
        warnings,
    )


def _label(c: Candidate) -> str:
    return model_name(c.order) + (f" order {c.order}" if c.order >= 2 else "")


def fit_trace(
    trace: Trace,
    *,
    level: Any = DEFAULT_LEVEL,
    model: str | None = None,
    order: int | None = None,
    max_order: int | None = None,
    budget: Budget | None = None,
) -> FitReport:
    """Fit :func:`fit`'s candidates to a parsed :class:`Trace` (see :func:`fit`); ``budget`` is ticked per candidate."""
    lvl = level if isinstance(level, Fraction) else parse_level(level)
    forced, top = _order_of(model, order, max_order)
    a = trace.arrivals
    n = int(a.size)
    ones = int(a.sum())
    if ones in (0, n):
        what = "arrivals (1)" if ones else "losses (0)"
        raise InvalidInput(
            "/arrivals",
            f"the trace holds only {what}: with one symbol only every estimate is 0 or 1, outside every "
            "channel kfio analyzes (Rohr, Marelli and Fu 2014, Assumption 1); a longer trace is needed",
        )
    orders = [forced] if forced is not None else list(range(0, top + 1))
    common = max(orders) if forced is None else forced
    cands = []
    for k in orders:
        if budget is not None:
            budget.tick("fit: candidate models")
        cands.append(candidate(a, k, common))
    notes = []
    if forced is not None:
        chosen = cands[0]
        if not chosen.complete:
            raise _too_short(chosen, n)
    else:
        scored = [c for c in cands if c.bic is not None and c.complete]
        if not scored:
            raise _too_short(cands[0], n)
        chosen = min(scored, key=lambda c: (c.bic, c.order))
        skipped = [_label(c) for c in cands if c not in scored]
        if skipped:
            notes.append(f"not scored (some history never occurs in the trace): {', '.join(skipped)}")
    est, trials = _parameters(chosen)
    m = len(trials)
    each = float(bonferroni_level(lvl, m))
    intervals = {name: clopper_pearson(k, nn, each) for name, (k, nn) in trials.items()}
    marginal = {name: clopper_pearson(k, nn, float(lvl)) for name, (k, nn) in trials.items()}
    if budget is not None:
        budget.tick("fit: run-length check")
    gof, warnings = _goodness(a, cands, chosen)
    warnings = list(warnings)
    if any(x in (0, 1) for x in est.values()):
        warnings.append(
            "an estimated probability is 0 or 1 (some history is always or never followed by an arrival in the "
            "trace): Theorem 1 of Rohr, Marelli and Fu (2014) does not cover such a channel (Assumption 1)"
        )
    scores = tuple(
        {
            "model": c.model,
            "order": c.order,
            "parameters": c.parameters,
            "log_likelihood": c.log_likelihood,
            "bic": c.bic,
            "chosen": c is chosen,
        }
        for c in cands
    )
    return FitReport(
        model=chosen.model,
        order=chosen.order,
        parameters={k: fraction_text(v) for k, v in est.items()},
        intervals=intervals,
        marginal_intervals=marginal,
        level=lvl,
        interval_method=interval_method(lvl, m),
        samples=n,
        counts=_counts(a, chosen),
        criterion=CRITERION if forced is None else "none: the model was given",
        scores=scores,
        goodness_of_fit=gof,
        channel=channel_of(chosen.model, chosen.order, est),
        trials=trials,
        estimates=est,
        source=trace.source,
        sequence=None if trace.sequence is None else trace.sequence.as_dict(),
        warnings=tuple(warnings),
        notes=tuple(list(trace.notes) + notes),
        forced=forced is not None,
    )


def refit(found: FitReport, level: Any) -> FitReport:
    """``found`` with its intervals at another joint ``level`` (same model and estimates)."""
    import dataclasses

    lvl = level if isinstance(level, Fraction) else parse_level(level, "--level")
    m = len(found.trials)
    return dataclasses.replace(
        found,
        level=lvl,
        intervals=found.joint_intervals(lvl),
        marginal_intervals={name: clopper_pearson(k, n, float(lvl)) for name, (k, n) in found.trials.items()},
        interval_method=interval_method(lvl, m),
    )


def fit(
    arrivals: Any,
    *,
    level: Any = DEFAULT_LEVEL,
    model: str | None = None,
    order: int | None = None,
    max_order: int | None = None,
    budget: BudgetLike | None = None,
) -> FitReport:
    """Fit a packet channel to a measured arrival trace, with exact estimates and confidence intervals.

    The candidates are Bernoulli (``lambda = #1 / N``), the Gilbert-Elliott
    arrival chain (``p = n(1->0) / n(1->*)``, ``q = n(0->1) / n(0->*)``;
    Gilbert 1960, Elliott 1963) and Markov chains of order ``2 .. max_order``
    (``P(1 | h) = n(h->1) / n(h->*)``; Yajnik, Moon, Kurose and Towsley 1999):
    the maximum-likelihood estimates, exact rationals.  The model with the
    smallest ``BIC = -2 log L + d log n`` (Schwarz 1978) is chosen; every
    parameter gets the exact binomial interval of Clopper and Pearson (1934),
    joint by Bonferroni (each at ``1 - (1 - level) / d``); the loss runs are
    checked against the model's run-length law (chi-square), with a warning
    when it does not fit.

    Parameters
    ----------
    arrivals:
        ``"0110..."`` (1 = arrived), a list or array of 0/1, or a trace read by
        :func:`kfio.fit.read_trace`.
    level:
        Joint confidence level in ``(0, 1)``, exact from its decimal text (default 0.95).
    model, order:
        Force a model (``"bernoulli"``, ``"gilbert_elliott"``, or
        ``"markov"`` with its ``order``) instead of choosing by BIC.
    max_order:
        Largest Markov order tried (default 4, at most 8).
    budget:
        Seconds (in ``[0.01, 3600]``) or a :class:`kfio.Budget`, ticked once
        per candidate model and once for the run-length check; default none.

    Returns
    -------
    FitReport
        ``channel`` drops into any request; ``to_dict()`` is ``kfio fit --json``.

    Raises
    ------
    InvalidInput
        An empty trace, one symbol only, a character other than 0/1, a trace
        too short for the model asked (the message says how many packets it needs).
    BudgetExceeded
        The fit did not fit the budget.

    Examples
    --------
    >>> import kfio
    >>> r = kfio.fit("1101101110110111", model="bernoulli")
    >>> r.parameters, r.channel
    ({'arrival_probability': '3/4'}, {'model': 'bernoulli', 'arrival_probability': '3/4'})
    """
    work = budget if isinstance(budget, Budget) else None
    if work is None and budget is not None:
        work = Budget(seconds=budget_seconds(budget))
    return fit_trace(as_trace(arrivals), level=level, model=model, order=order, max_order=max_order, budget=work)


__all__ = [
    "CRITERION",
    "DEFAULT_LEVEL",
    "DEFAULT_MAX_ORDER",
    "FitReport",
    "MAX_ORDER",
    "channel_of",
    "fit",
    "fit_trace",
    "parse_level",
]
