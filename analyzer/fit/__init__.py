"""From a measured packet trace to a channel model, and to a verdict at a stated confidence.

``kfio fit TRACE``: the maximum-likelihood Bernoulli, Gilbert-Elliott and
Markov models of a trace (exact rationals), chosen by BIC (Schwarz 1978),
with exact binomial intervals (Clopper and Pearson 1934) and a run-length
check; ``kfio analyze|loop --trace``: whether the whole confidence region lies
in kfio's exact stable set.  See ``docs/traces.md``.
"""

from __future__ import annotations

import sys
import types
from typing import Any

from ._confidence import ConfidenceVerdict, confidence_verdict
from ._estimate import transition_counts
from ._fit import DEFAULT_LEVEL, DEFAULT_MAX_ORDER, MAX_ORDER, FitReport, channel_of, fit, fit_trace, parse_level, refit
from ._read import parse_trace_text, read_trace
from ._requests import (
    analyze_at_confidence,
    fit_link,
    fit_request,
    load_trace_loop_request,
    load_trace_request,
    loop_at_confidence,
    resolve_traces,
    with_trace,
)
from ._runs import complete_runs, run_length_law, run_test
from ._trace import (
    DEFAULT_MODULUS,
    DEFAULT_WINDOW,
    SequenceStats,
    Trace,
    arrivals_from_csv,
    arrivals_from_sequence,
    arrivals_from_text,
    as_trace,
)

__all__ = [
    "DEFAULT_LEVEL",
    "DEFAULT_MAX_ORDER",
    "DEFAULT_MODULUS",
    "DEFAULT_WINDOW",
    "MAX_ORDER",
    "ConfidenceVerdict",
    "FitReport",
    "SequenceStats",
    "Trace",
    "analyze_at_confidence",
    "arrivals_from_csv",
    "arrivals_from_sequence",
    "arrivals_from_text",
    "as_trace",
    "channel_of",
    "complete_runs",
    "confidence_verdict",
    "fit",
    "fit_link",
    "fit_request",
    "fit_trace",
    "load_trace_loop_request",
    "load_trace_request",
    "loop_at_confidence",
    "parse_level",
    "parse_trace_text",
    "read_trace",
    "refit",
    "resolve_traces",
    "run_length_law",
    "run_test",
    "transition_counts",
    "with_trace",
]


class _CallableModule(types.ModuleType):
    """``kfio.fit`` is both this package and the function :func:`fit`: calling the package calls it."""

    def __call__(self, *args: Any, **kwargs: Any) -> FitReport:
        return fit(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
