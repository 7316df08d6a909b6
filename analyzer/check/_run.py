"""Evaluate a check file: one analyze / bounds / simulate run per entry and command, in parallel.

The runs are the same functions as ``kfio analyze|bounds|simulate`` (each
entry's requirements are judged on that command's JSON report, see
:mod:`kfio.check._requirements`), in forked worker processes (:func:`kfio._workers.run_all`).
Each run has the check's ``point_budget_s`` as its cooperative :class:`kfio.Budget`;
the whole check has ``time_budget_s``, after which every worker is killed
(a run stuck in C code cannot outlive it) and the requirements not yet
judged are errors of kind ``budget-exceeded``.  A run whose worker died is an
error too: ``budget-exceeded`` when it died of a failed allocation under the
memory limit (as a ``MemoryError`` in Python is), else ``internal``.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Callable, ClassVar, cast

from .._budget import Budget
from .._reporting import Report, ReportPart
from .._workers import Died, run_all
from ..errors import AnalyzerError, BudgetExceeded, InvalidInput, MissingDependency, NumericalFailure
from ..model import fraction_text, values_withheld
from ._requirements import judge
from ._spec import CheckSpec

#: Error kinds of a requirement that could not be judged.
ERROR_KINDS = (
    "budget-exceeded",
    "numerical-failure",
    "invalid-input",
    "missing-dependency",
    "analysis-error",
    "internal",
)


@dataclass(frozen=True)
class Outcome(ReportPart):
    """One requirement of one entry, judged.

    ``status`` is ``pass``, ``fail`` or ``error`` (``error_kind`` then says
    which of :data:`ERROR_KINDS`); ``measured`` and ``required`` are texts.
    """

    entry: str
    requirement: str
    status: str
    measured: str
    required: str
    detail: str
    seconds: float
    error_kind: str | None = None
    #: The exact measured value's text and its float, and the exact limit's text, where they exist;
    #: :meth:`exact_of` reads them (``exact_of("measured")``, ``exact_of("required")``).  The texts above
    #: are for people, rounded where the value is long.
    measured_exact: str | None = None
    measured_approx: float | None = None
    required_exact: str | None = None

    def exact_names(self) -> tuple[str, ...]:
        """The names :meth:`exact_of` accepts: ``measured`` and ``required``."""
        return ("measured", "required")

    def _exact_pair(self, key: str) -> tuple[Any, Any]:
        return getattr(self, key + "_exact"), self.measured_approx if key == "measured" else None


@dataclass(frozen=True, repr=False)
class CheckResult(Report):
    """All outcomes of a check, in the file's order (entries, then requirements)."""

    _repr_fields: ClassVar[tuple[str, ...]] = ("status", "tally", "seconds", "workers", "source")

    outcomes: tuple[Outcome, ...]
    seconds: float
    workers: int
    source: str = "<check>"

    @property
    def status(self) -> str:
        """``pass`` (every requirement holds), ``fail`` (one fails, or could not be judged for a reason
        other than the budget), or ``budget`` (none fails, but the budget stopped some)."""
        if any(o.status == "fail" for o in self.outcomes):
            return "fail"
        if any(o.status == "error" and o.error_kind != "budget-exceeded" for o in self.outcomes):
            return "fail"
        if any(o.status == "error" for o in self.outcomes):
            return "budget"
        return "pass"

    @property
    def tally(self) -> dict[str, int]:
        """How many requirements passed, failed, could not be judged."""
        return {s: sum(1 for o in self.outcomes if o.status == s) for s in ("pass", "fail", "error")}


def _worst_rate(report: Any) -> tuple[float | None, str | None]:
    """The largest ``|alpha_k|^2 sigma_k`` of a :class:`StabilityReport`, exactly when both factors are rational."""
    import sympy

    from ..model import parse_number

    best: tuple[float, Fraction | None] | None = None
    for b in report.blocks:
        if b.rate is None:
            continue
        exact = None
        beta = b.modulus_sq_expr
        if isinstance(beta, sympy.Rational) and b.sigma_exact is not None:
            try:
                exact = Fraction(int(beta.p), int(beta.q)) * parse_number(b.sigma_exact, "/")
            except InvalidInput:  # an algebraic sigma ("sqrt(30)/10"): the float is what there is
                exact = None
        if best is None or b.rate > best[0]:
            best = (b.rate, exact)
    if best is None:
        return None, None
    return best[0], (fraction_text(best[1]) if best[1] is not None else None)


def link_points(req: Any) -> dict[str, str]:
    """The request's value of each link parameter a loop's critical value varies, by its JSON pointer.

    ``{"/actuator_channel/arrival_probability": "1/2", ...}``: where the loop's own operating point
    lies on each link, to find the stable interval it belongs to (:mod:`kfio.check._requirements`).
    """
    from ..loop import parameter_of, sensor_links

    links = [(lk.pointer, lk.channel) for lk, _rows in sensor_links(req)] + [("/actuator_channel", req.actuator)]
    out = {}
    for pointer, channel in links:
        found = parameter_of(pointer, channel)
        if found is not None:
            out[found[0]] = fraction_text(channel.params[found[0].rsplit("/", 1)[1]])
    return out


def run_one(command: str, tree: dict[str, Any], seconds: float) -> tuple[str, Any, float]:
    """Run ``command`` on the request ``tree``: ``("ok", payload, s)`` or ``("error", (kind, message), s)``.

    Never raises for an analysis failure (it travels back from a worker as data).
    """
    from ..model import DEFAULT_LIMITS, parse_request

    t0 = time.perf_counter()
    try:
        if command == "loop":  # the report of ``kfio loop --json`` (kfio.loop)
            from ..loop import analyze_loop, parse_loop_request

            loop_request = parse_loop_request(tree)
            payload: dict[str, Any] = {
                "report": analyze_loop(loop_request).to_dict(),
                "link_points": link_points(loop_request),
            }
            return "ok", payload, time.perf_counter() - t0
        from ..fit import resolve_traces

        tree, fits = resolve_traces(tree)  # a trace channel: the channel fitted to it
        request = parse_request(tree, DEFAULT_LIMITS.for_command(command))
        budget = Budget(seconds=seconds)
        if command == "analyze":
            from ..stability import analyze

            report = analyze(request, budget)
            rate, rate_exact = _worst_rate(report)
            out = report.to_dict()
            if "/channel" in fits:  # the verdict of the whole confidence region judges `verdict`
                from ..fit import analyze_at_confidence

                out["fit"] = analyze_at_confidence(request, fits["/channel"], report.verdict, budget).to_dict()
            payload = {"report": out, "worst_rate": rate, "worst_rate_exact": rate_exact}
        elif command == "bounds":
            from ..riccati_bounds import compute_bounds

            payload = {"report": compute_bounds(request, budget=budget).to_dict()}
        else:
            from ..simulation import simulate

            payload = {"report": simulate(request, budget=budget).to_dict()}
        return "ok", payload, time.perf_counter() - t0
    except BudgetExceeded as exc:
        error = ("budget-exceeded", str(exc))
    except NumericalFailure as exc:
        error = ("numerical-failure", str(exc))
    except InvalidInput as exc:
        error = ("invalid-input", f"{exc.field}: {exc.rule}")
    except MissingDependency as exc:
        error = ("missing-dependency", str(exc))
    except AnalyzerError as exc:
        error = ("analysis-error", str(exc))
    except MemoryError:
        error = ("budget-exceeded", "the run needs more memory than its limit")
    except Exception as exc:  # noqa: BLE001 - one bad entry must not end the check; the outcome says it is a bug
        error = ("internal", f"{type(exc).__name__}: {exc}")
    return "error", error, time.perf_counter() - t0


def _run_quoting_nothing(command: str, tree: dict[str, Any], seconds: float) -> tuple[str, Any, float]:
    """:func:`run_one` with the files' values withheld from its messages: they go to logs and JUnit."""
    with values_withheld():
        return run_one(command, tree, seconds)


def _from_worker(answer: Any) -> tuple[str, Any, float]:
    """A run's answer as :func:`run_one` gives it, also when its worker died (:class:`kfio._workers.Died`)."""
    if not isinstance(answer, Died):
        return cast("tuple[str, Any, float]", answer)
    if answer.out_of_memory:
        return "error", ("budget-exceeded", "the run needs more memory than its limit"), 0.0
    return "error", ("internal", f"the worker process died during the run (exit code {answer.exit_code})"), 0.0


def _preload(commands: set[str]) -> None:
    """Import what the runs need before forking, so every worker shares it."""
    if "analyze" in commands:
        import kfio.stability  # noqa: F401
    if "bounds" in commands:
        import kfio.riccati_bounds  # noqa: F401
    if "simulate" in commands:
        import kfio.simulation  # noqa: F401
    if "loop" in commands:
        import kfio.loop  # noqa: F401


def run_check(
    spec: CheckSpec,
    *,
    workers: int | None = None,
    time_budget_s: float | None = None,
    memory_bytes: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> CheckResult:
    """Judge every requirement of ``spec``.

    Parameters
    ----------
    workers:
        Worker processes (default: cores, at most one per run); ``1`` runs in
        this process, with the cooperative budgets only.
    time_budget_s:
        The whole check's budget (default ``spec.time_budget_s``).
    memory_bytes:
        Address-space limit of each worker process.
    progress:
        Called with ``(runs done, runs)`` as runs finish.
    """
    t0 = time.perf_counter()
    tasks = [(i, c) for i, e in enumerate(spec.entries) for c in e.commands]
    budget = time_budget_s if time_budget_s is not None else spec.time_budget_s
    deadline = time.monotonic() + budget
    point = min(spec.point_budget_s, budget)
    n = max(1, min(workers or os.cpu_count() or 1, len(tasks)))
    results: dict[tuple[int, str], tuple[str, Any, float]] = {}
    if n == 1 and workers == 1:
        for k, (i, c) in enumerate(tasks):
            left = deadline - time.monotonic()
            if left <= 0:
                break
            results[(i, c)] = _run_quoting_nothing(c, spec.entries[i].request_for(c), min(point, left))
            if progress:
                progress(k + 1, len(tasks))
    else:
        _preload({c for _, c in tasks})  # before the workers fork: they share the imports
        answers = run_all(
            _run_quoting_nothing,
            [((c, spec.entries[i].request_for(c)), point) for i, c in tasks],
            workers=n,
            deadline=deadline,
            memory_bytes=memory_bytes,
            progress=progress,
        )
        results = {tasks[k]: _from_worker(a) for k, a in answers.items()}
    outcomes = []
    for i, entry in enumerate(spec.entries):
        for req in entry.requirements:
            got = results.get((i, req.command))
            if got is None or got[0] == "error":
                kind, message, seconds = (
                    (
                        "budget-exceeded",
                        f"the check's time budget of {budget:g} s ran out before this run finished",
                        0.0,
                    )
                    if got is None
                    else (*got[1], got[2])
                )
                outcomes.append(
                    Outcome(
                        entry.name,
                        req.key,
                        "error",
                        "none",
                        req.required,
                        message,
                        seconds,
                        kind,
                        required_exact=req.required_exact,
                    )
                )
                continue
            status, payload, seconds = got
            j = judge(req, payload)
            kind = "numerical-failure" if j.status == "error" else None
            outcomes.append(
                Outcome(
                    entry.name,
                    req.key,
                    j.status,
                    j.measured,
                    req.required,
                    j.detail,
                    seconds,
                    kind,
                    j.exact,
                    j.approx,
                    req.required_exact,
                )
            )
    return CheckResult(tuple(outcomes), time.perf_counter() - t0, n, spec.source)


__all__ = ["ERROR_KINDS", "CheckResult", "Outcome", "run_check", "run_one"]
