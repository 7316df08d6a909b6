"""Packet traces from what people log: 0/1 arrival columns and received sequence numbers.

A trace is the arrival sequence ``a_1 .. a_N`` (1 = the packet arrived, 0 =
it was lost) of one packet stream.  Three sources are read here:

* arrival text: one ``0``/``1`` per line (a line may hold several, read left
  to right; blank lines and lines starting with ``#`` are skipped), or the
  same characters in one string (the ``arrivals`` of an HTTP request);
* a CSV file with a header row: one column per sensor, named;
* received sequence numbers, one per line: a gap is a run of losses,
  a duplicate is ignored (and counted), a packet that arrives late but within
  ``window`` packets of the newest one fills its gap (and is counted as
  reordered), and the counter wraps modulo ``modulus``.

Every refusal is an :class:`kfio.errors.InvalidInput` naming the field (a
JSON pointer, or ``LABEL line K`` for a file) and the rule.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import InvalidInput, LimitExceeded

#: Longest trace kfio fits (packets): ten million arrivals is about three hours at 1 kHz.
MAX_SAMPLES = 10_000_000
#: Default modulus of sequence numbers: 16-bit counters (RTP, most radio and fieldbus stacks).
DEFAULT_MODULUS = 1 << 16
#: Default reordering window (packets): a packet older than this behind the newest one is refused,
#: the size of the IPsec and DTLS anti-replay windows.
DEFAULT_WINDOW = 64


@dataclass(frozen=True)
class SequenceStats:
    """What parsing received sequence numbers found.

    Attributes
    ----------
    received:
        Sequence numbers read (duplicates included).
    lost:
        Packets never received between the first and the newest one.
    duplicates:
        Numbers received more than once (each extra copy counted).
    reordered:
        Packets that arrived after a newer one and filled their gap.
    wraps:
        Times the counter wrapped past ``modulus``.
    before_start:
        Late packets older than the first one received (outside the trace, ignored).
    """

    received: int
    lost: int
    duplicates: int
    reordered: int
    wraps: int
    before_start: int
    modulus: int | None
    window: int

    def as_dict(self) -> dict[str, Any]:
        """The JSON object of these counts."""
        return {
            "received": self.received,
            "lost": self.lost,
            "duplicates": self.duplicates,
            "reordered": self.reordered,
            "wraps": self.wraps,
            "before_start": self.before_start,
            "modulus": self.modulus,
            "window": self.window,
        }


@dataclass(frozen=True)
class Trace:
    """One arrival sequence: ``arrivals[t]`` is 1 when packet ``t`` arrived.

    ``source`` says where it came from (``"arrivals"``, ``"column x"``,
    ``"sequence numbers"``); ``sequence`` holds what sequence-number parsing
    found, when the trace came from sequence numbers.
    """

    arrivals: np.ndarray
    source: str = "arrivals"
    sequence: SequenceStats | None = None
    notes: tuple[str, ...] = field(default=())

    def __len__(self) -> int:
        return int(self.arrivals.size)


def _checked(arr: np.ndarray, where: str) -> np.ndarray:
    if arr.size == 0:
        raise InvalidInput(where, "the trace is empty: give at least one arrival (1) and one loss (0)")
    if arr.size > MAX_SAMPLES:
        raise LimitExceeded(where, f"a trace may hold at most {MAX_SAMPLES} packets; got {arr.size}")
    return arr


def arrivals_from_text(text: str, where: str = "/arrivals", label: str | None = None) -> np.ndarray:
    """The 0/1 array of an arrival text: lines of ``0``/``1`` characters.

    ``#`` starts a comment line; blank lines are skipped.  Any other
    character is refused, naming its line (``label line K``) or, for a
    one-line string, the field ``where`` and the character's position.
    """
    if not isinstance(text, str):
        raise InvalidInput(where, f"expected a string of 0 and 1 characters; got {type(text).__name__}")
    chunks: list[bytes] = []
    lines = text.splitlines() if label is not None or "\n" in text else [text]
    for number, line in enumerate(lines, start=1):
        body = line.strip(" \t\r")
        if not body or body.startswith("#"):
            continue
        raw = body.encode("utf-8", "surrogatepass")
        bad = raw.translate(None, b"01")
        if bad:
            pos = next(i for i, ch in enumerate(body) if ch not in "01")
            shown = repr(body[pos])
            at = f"{label} line {number}" if label is not None else where
            place = f"line {number}, column {pos + 1}" if label is None and len(lines) > 1 else f"position {pos + 1}"
            raise InvalidInput(
                at, f"a trace holds only the characters 0 (lost) and 1 (arrived); found {shown} at {place}"
            )
        chunks.append(raw)
    arr = np.frombuffer(b"".join(chunks), dtype=np.uint8) - ord("0")
    return _checked(arr.astype(np.uint8), label or where)


def arrivals_from_list(values: Sequence[Any] | np.ndarray, where: str = "/arrivals") -> np.ndarray:
    """The 0/1 array of a list of integers ``0``/``1`` (booleans are refused: JSON has no 0/1 booleans)."""
    if isinstance(values, np.ndarray):
        values = values.tolist()
    out = np.empty(len(values), dtype=np.uint8)
    for i, v in enumerate(values):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v not in (0, 1):
            raise InvalidInput(f"{where}/{i}", f"a trace holds only 0 (lost) and 1 (arrived); got {v!r:.40}")
        out[i] = v
    return _checked(out, where)


def arrivals_from_csv(text: str, columns: Sequence[str], label: str = "TRACE") -> dict[str, np.ndarray]:
    """``{column: 0/1 array}`` of the named columns of a CSV text with a header row."""
    reader = csv.reader(io.StringIO(text))
    try:
        header = next(reader)
    except StopIteration:
        raise InvalidInput(
            f"{label} line 1", "the CSV file is empty: expected a header row naming the columns"
        ) from None
    except csv.Error as exc:
        raise InvalidInput(f"{label} line 1", f"not a CSV file: {exc}") from None
    names = [h.strip() for h in header]
    index = {}
    for col in columns:
        if col not in names:
            raise InvalidInput("--column", f"no column {col[:64]!r} in the header; columns are {names[:20]}")
        index[col] = names.index(col)
    values: dict[str, list[int]] = {c: [] for c in columns}
    try:
        for row in reader:
            if not row or all(not x.strip() for x in row):
                continue
            for col, j in index.items():
                cell = row[j].strip() if j < len(row) else ""
                if cell not in ("0", "1"):
                    raise InvalidInput(
                        f"{label} line {reader.line_num}",
                        f"column {col[:64]!r} must hold 0 (lost) or 1 (arrived); got {cell[:20]!r}",
                    )
                values[col].append(int(cell))
    except csv.Error as exc:
        raise InvalidInput(f"{label} line {reader.line_num}", f"not a CSV file: {exc}") from None
    return {c: _checked(np.array(v, dtype=np.uint8), f"--column {c}") for c, v in values.items()}


def _sequence_numbers(text: str, label: str) -> list[tuple[int, int]]:
    out = []
    for number, line in enumerate(text.splitlines(), start=1):
        body = line.strip(" \t\r")
        if not body or body.startswith("#"):
            continue
        if not (body.isascii() and body.isdigit()) or len(body) > 20:
            raise InvalidInput(
                f"{label} line {number}", f"a sequence number is a non-negative integer; got {body[:20]!r}"
            )
        out.append((number, int(body)))
    return out


def arrivals_from_sequence(
    text: str | Sequence[int],
    *,
    modulus: int | None = DEFAULT_MODULUS,
    window: int = DEFAULT_WINDOW,
    label: str = "TRACE",
) -> Trace:
    """The trace of received sequence numbers (one per line, in the order received).

    The trace runs from the first number received to the newest one; every
    number in between that never arrives is a loss.  With ``modulus`` ``M``
    the counter wraps: each number is read as the unwrapped value nearest
    the newest one so far (within ``M / 2``).  A number behind the newest by
    ``1 .. window`` packets is a late packet (it fills its gap) or a
    duplicate; further behind, it is refused: the log is not one stream, or
    the counter was reset.

    Parameters
    ----------
    modulus:
        The counter's modulus (``2^16`` by default); ``None`` for a counter
        that never wraps.
    window:
        How far back (packets) a late packet may come.
    """
    if modulus is not None and (isinstance(modulus, bool) or not isinstance(modulus, int) or modulus < 2):
        raise InvalidInput("--modulus", "the sequence-number modulus is an integer >= 2 (or none)")
    if isinstance(window, bool) or not isinstance(window, int) or not 0 <= window <= 1 << 20:
        raise InvalidInput("--window", f"the reordering window is an integer in [0, {1 << 20}] packets")
    if isinstance(text, str):
        numbers = _sequence_numbers(text, label)
    else:
        numbers = []
        for i, v in enumerate(text):
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0:
                raise InvalidInput(f"/sequence/{i}", f"a sequence number is a non-negative integer; got {v!r:.40}")
            numbers.append((i + 1, int(v)))
    if not numbers:
        raise InvalidInput(label, "the trace is empty: no sequence number was read")
    first_line, first = numbers[0]
    if modulus is not None and first >= modulus:
        raise InvalidInput(
            f"{label} line {first_line}",
            f"sequence number {first} is not below the modulus {modulus}; give the counter's modulus (--modulus)",
        )
    newest = first  # unwrapped
    received: set[int] = {first}
    duplicates = reordered = wraps = before = 0
    for line, s in numbers[1:]:
        if modulus is not None:
            if s >= modulus:
                raise InvalidInput(
                    f"{label} line {line}",
                    f"sequence number {s} is not below the modulus {modulus}; give the counter's modulus (--modulus)",
                )
            delta = (s - newest) % modulus
            if delta > modulus // 2:
                delta -= modulus
        else:
            delta = s - newest
        u = newest + delta
        if delta > 0:
            if modulus is not None and u // modulus > newest // modulus:
                wraps += u // modulus - newest // modulus
            if u - first >= MAX_SAMPLES:
                raise LimitExceeded(f"{label} line {line}", f"a trace may span at most {MAX_SAMPLES} packets")
            newest = u
            received.add(u)
            continue
        if -delta > window:
            raise InvalidInput(
                f"{label} line {line}",
                f"sequence number {s} goes back {-delta} packets behind the newest ({newest % modulus if modulus else newest}), "
                f"beyond the reordering window of {window} packets: the log mixes streams or the counter was reset",
            )
        if u < first:
            before += 1
        elif u in received:
            duplicates += 1
        else:
            received.add(u)
            reordered += 1
    arr = np.zeros(newest - first + 1, dtype=np.uint8)
    arr[np.fromiter((u - first for u in received if u >= first), dtype=np.int64)] = 1
    stats = SequenceStats(
        received=len(numbers),
        lost=int(arr.size - arr.sum()),
        duplicates=duplicates,
        reordered=reordered,
        wraps=wraps,
        before_start=before,
        modulus=modulus,
        window=window,
    )
    notes = []
    if duplicates:
        notes.append(f"{duplicates} duplicate sequence numbers ignored")
    if reordered:
        notes.append(f"{reordered} packets arrived out of order and were counted as arrived")
    if before:
        notes.append(f"{before} late packets older than the first one received were outside the trace")
    return Trace(_checked(arr, label), "sequence numbers", stats, tuple(notes))


def as_trace(arrivals: Any, where: str = "/arrivals") -> Trace:
    """A :class:`Trace` from a string of ``0``/``1``, a list of 0/1 integers, a 0/1 array or a :class:`Trace`."""
    if isinstance(arrivals, Trace):
        return arrivals
    if isinstance(arrivals, str):
        return Trace(arrivals_from_text(arrivals, where))
    if isinstance(arrivals, (list, tuple, np.ndarray)):
        return Trace(arrivals_from_list(arrivals, where))
    raise InvalidInput(
        where, f'expected the arrivals as a string such as "0110" or a list of 0 and 1; got {type(arrivals).__name__}'
    )


__all__ = [
    "DEFAULT_MODULUS",
    "DEFAULT_WINDOW",
    "MAX_SAMPLES",
    "SequenceStats",
    "Trace",
    "arrivals_from_csv",
    "arrivals_from_list",
    "arrivals_from_sequence",
    "arrivals_from_text",
    "as_trace",
]
