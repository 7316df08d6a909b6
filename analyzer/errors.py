"""One exception hierarchy for the analyzer (STYLE.md, habit 4).

Every error subclasses :class:`AnalyzerError` *and* a built-in, so callers can
catch either.  Input errors carry a JSON pointer (``field``) into the request
and the rule that was broken; the CLI maps them to exit code 2 and the HTTP
service to status 422.  A missing optional package is not bad input: it is
:class:`MissingDependency` (CLI exit code 9, HTTP status 503).
"""

from __future__ import annotations

from typing import Any

#: Characters of one client value (a key, a string, a path) that an error message may quote.
ECHO_LIMIT = 100
#: Characters of an error's field pointer and of its rule: a message stays small whatever the request held.
FIELD_LIMIT = 1000
RULE_LIMIT = 2000


def clip(text: str, limit: int = ECHO_LIMIT) -> str:
    """``text`` cut to ``limit`` characters, an ellipsis marking the cut.

    Examples
    --------
    >>> clip("abc", 5), clip("x" * 10, 5)
    ('abc', 'xxxxx...')
    """
    return text if len(text) <= limit else text[:limit] + "..."


def clip_pointer(pointer: str) -> str:
    """A JSON pointer for a message: each reference token clipped (:func:`clip`), the whole at most
    :data:`FIELD_LIMIT` characters (its start and its end kept, the middle elided).

    A client's key may be a megabyte; the pointer that names it must not be.

    Examples
    --------
    >>> clip_pointer("/system/" + "k" * 150)[:20], len(clip_pointer("/system/" + "k" * 150))
    ('/system/kkkkkkkkkkkk', 111)
    """
    if len(pointer) <= ECHO_LIMIT:
        return pointer
    tokens = [clip(t) for t in pointer.split("/")]
    # "~0"/"~1" are one escaped character: a cut must not leave half an escape at the end
    tokens = [t[:-4] + "..." if t.endswith("~...") else t for t in tokens]
    text = "/".join(tokens)
    if len(text) > FIELD_LIMIT:
        half = FIELD_LIMIT // 2
        text = text[:half] + "/.../" + text[-half:]
    return text


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
        # bounded here, once: every door (CLI line, problem document, check report) shows these two
        self.field = clip_pointer(field or "/")
        self.rule = clip(rule, RULE_LIMIT)
        super().__init__(f"{self.field}: {self.rule}")


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
