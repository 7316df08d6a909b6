"""From a measured packet trace to a channel model, and to a verdict at a stated confidence.

``kfio fit TRACE``: the maximum-likelihood Bernoulli, Gilbert-Elliott and
Markov models of a trace (exact rationals), chosen by BIC (Schwarz 1978),
with exact binomial intervals (Clopper and Pearson 1934) and a run-length
check; ``kfio analyze|loop --trace``: whether the whole confidence region lies
in kfio's exact stable set.  See ``docs/traces.md``.

``kfio.fit`` (the attribute of the package ``kfio``) is the typed function
:func:`fit`; this subpackage stays importable under the same name
(``from kfio.fit import fit_trace``).  Its names load on first use, so
importing it costs nothing until then: ``kfio`` imports it at start-up to
keep the function, not the subpackage, as its attribute.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_names

#: Public name -> the private module (relative to this package) that defines it.
_LAZY = {
    "analyze_at_confidence": "._requests",
    "arrivals_from_csv": "._trace",
    "arrivals_from_sequence": "._trace",
    "arrivals_from_text": "._trace",
    "as_trace": "._trace",
    "channel_of": "._fit",
    "complete_runs": "._runs",
    "confidence_verdict": "._confidence",
    "ConfidenceVerdict": "._confidence",
    "DEFAULT_LEVEL": "._fit",
    "DEFAULT_MAX_ORDER": "._fit",
    "DEFAULT_MODULUS": "._trace",
    "DEFAULT_WINDOW": "._trace",
    "fit": "._fit",
    "fit_link": "._requests",
    "fit_request": "._requests",
    "fit_trace": "._fit",
    "FitReport": "._fit",
    "load_trace_loop_request": "._requests",
    "load_trace_request": "._requests",
    "loop_at_confidence": "._requests",
    "MAX_ORDER": "._fit",
    "parse_level": "._fit",
    "parse_trace_text": "._read",
    "read_trace": "._read",
    "refit": "._fit",
    "resolve_traces": "._requests",
    "run_length_law": "._runs",
    "run_test": "._runs",
    "SequenceStats": "._trace",
    "Trace": "._trace",
    "transition_counts": "._estimate",
    "with_trace": "._requests",
}

if TYPE_CHECKING:
    from ._confidence import ConfidenceVerdict, confidence_verdict
    from ._estimate import transition_counts
    from ._fit import (
        DEFAULT_LEVEL,
        DEFAULT_MAX_ORDER,
        MAX_ORDER,
        FitReport,
        channel_of,
        fit,
        fit_trace,
        parse_level,
        refit,
    )
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


__getattr__, __dir__ = lazy_names(__name__, _LAZY, globals())


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
