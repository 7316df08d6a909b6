"""Read a trace file: 0/1 lines, CSV columns, or received sequence numbers."""

from __future__ import annotations

from collections.abc import Sequence

from ..errors import InvalidInput
from ..model import read_limited
from ._trace import (
    DEFAULT_MODULUS,
    DEFAULT_WINDOW,
    Trace,
    arrivals_from_csv,
    arrivals_from_sequence,
    arrivals_from_text,
)

#: Largest trace file read (bytes): ten million packets of one character and a newline.
MAX_TRACE_BYTES = 20_000_000


def read_trace_text(path: str, label: str = "TRACE") -> str:
    """The text of a trace file (``-``: standard input), refusing one over :data:`MAX_TRACE_BYTES`."""
    data = read_limited(path, MAX_TRACE_BYTES, label, f"a trace file may hold at most {MAX_TRACE_BYTES} bytes")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InvalidInput(label, f"a trace file is UTF-8 text; byte {exc.start} is not") from None


def parse_trace_text(
    text: str,
    *,
    columns: Sequence[str] = (),
    sequence: bool = False,
    modulus: int | None = DEFAULT_MODULUS,
    window: int = DEFAULT_WINDOW,
    label: str = "TRACE",
) -> dict[str, Trace]:
    """The traces of a file's text, by name: ``{"trace": ...}``, or one per CSV column.

    Parameters
    ----------
    columns:
        CSV column names (the file has a header row); one trace per column.
    sequence:
        The file lists received sequence numbers, one per line
        (:func:`kfio.fit._trace.arrivals_from_sequence`: gaps are losses).
    modulus, window:
        The sequence counter's modulus (``None``: it never wraps) and how far
        back a late packet may come.
    """
    if columns and sequence:
        raise InvalidInput("--sequence", "a trace is either CSV columns of 0/1 or sequence numbers, not both")
    if columns:
        return {c: Trace(a, f"column {c}") for c, a in arrivals_from_csv(text, columns, label).items()}
    if sequence:
        return {"trace": arrivals_from_sequence(text, modulus=modulus, window=window, label=label)}
    return {"trace": Trace(arrivals_from_text(text, label=label), "arrivals")}


def read_trace(
    path: str,
    *,
    columns: Sequence[str] = (),
    sequence: bool = False,
    modulus: int | None = DEFAULT_MODULUS,
    window: int = DEFAULT_WINDOW,
) -> dict[str, Trace]:
    """:func:`parse_trace_text` of the file ``path`` (``-``: standard input); errors name ``path line K``."""
    label = "TRACE" if path == "-" else path
    return parse_trace_text(
        read_trace_text(path, label), columns=columns, sequence=sequence, modulus=modulus, window=window, label=label
    )


__all__ = ["MAX_TRACE_BYTES", "parse_trace_text", "read_trace", "read_trace_text"]
