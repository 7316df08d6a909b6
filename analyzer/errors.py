"""One exception hierarchy for the analyzer (STYLE.md, habit 4).

Every error subclasses :class:`AnalyzerError` *and* a built-in, so callers can
catch either.  Input errors carry a JSON pointer (``field``) into the request
and the rule that was broken; the CLI maps them to exit code 2 and the HTTP
service to status 422.  A missing optional package is not bad input: it is
:class:`MissingDependency` (CLI exit code 9, HTTP status 503).
"""

from __future__ import annotations

from typing import Any


class AnalyzerError(Exception):
    """Base class of every error raised by :mod:`kfio`."""


class InvalidInput(AnalyzerError, ValueError):
    """The request breaks a rule.

    Parameters
    ----------
    field:
        JSON pointer (RFC 6901) to the offending value, e.g. ``/system/A/0/1``.
    rule:
        The rule that was broken, in one sentence.
    """

    def __init__(self, field: str, rule: str) -> None:
        self.field = field or "/"
        self.rule = rule
        super().__init__(f"{self.field}: {rule}")


class AssumptionViolation(InvalidInput):
    """The request is well formed but outside the hypotheses of the theorem used.

    Example: a channel probability of exactly 0 or 1 violates Assumption 1 of
    Rohr, Marelli and Fu (2014), so Theorem 1 gives no verdict for it.
    """


class LimitExceeded(InvalidInput):
    """A size limit (dimension, Markov order, digits, steps, ...) is exceeded."""


class BudgetExceeded(AnalyzerError, TimeoutError):
    """A computation needed more work than its budget allows.

    Attributes
    ----------
    partial:
        What the computation had proved when it stopped, as a JSON-ready
        dict, or ``None``.  The multi-sensor search of ``sigma_k`` sets it to
        the certified bracket on ``sigma_k`` (docs/sigma.md, "When the budget
        runs out"); the HTTP problem and the CLI show it.
    """

    partial: dict[str, Any] | None = None


class NumericalFailure(AnalyzerError, ArithmeticError):
    """A numerical step could not be completed or certified."""


class MissingDependency(AnalyzerError, ImportError):
    """A package kfio needs for this feature is not installed.

    Not the request's fault, so never "invalid input": the CLI exits with
    code 9 and the HTTP service answers 503.  The message names the package
    and a command that works from where the user is.

    Parameters
    ----------
    package:
        The distribution name, e.g. ``"dask[distributed]"``.
    feature:
        What needs it, e.g. ``"the Dask sweep engine"``.
    hint:
        What to do instead, e.g. ``"or run kfio sweep --serial"``.
    """

    def __init__(self, package: str, feature: str, hint: str = "") -> None:
        self.package = package
        self.feature = feature
        self.hint = hint
        text = f"{feature} needs the package {package!r}, which is not installed: pip install {package!r}"
        super().__init__(f"{text} ({hint})" if hint else text)
