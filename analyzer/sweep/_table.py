"""Sweep tables: JSON Lines, CSV and Parquet (via pyarrow, the ``sweep`` extra).

:class:`TableWriter` writes the rows as they come (in index order), so a
sweep of a million points never holds its table: CSV and JSON Lines go
straight to the file; Parquet rows are spooled to a JSON Lines file beside it
and written in row groups at the end, with each column's type the one
:func:`pyarrow.table` infers from the whole column.
"""

from __future__ import annotations

import csv
import io
import json
import os
import tempfile
from pathlib import Path
from typing import IO, Any, Iterable, Iterator, Sequence

from ..errors import InvalidInput, MissingDependency

FORMATS = ("csv", "parquet", "jsonl")

#: Rows per Parquet row group (and per batch read back from the spool).
PARQUET_BATCH = 65536


def format_of(path: str | Path) -> str:
    """The table format a file name asks for (``.csv``, ``.parquet``, ``.jsonl``)."""
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix == "json":
        suffix = "jsonl"
    if suffix not in FORMATS:
        raise InvalidInput("--out", f"the table's file name must end in one of {['.' + f for f in FORMATS]}")
    return suffix


def jsonl_line(record: dict[str, Any]) -> str:
    """One row as a JSON line (no NaN; keys in table order)."""
    return json.dumps(record, allow_nan=False, separators=(",", ":"))


def csv_text(columns: Sequence[str], records: Iterable[dict[str, Any]]) -> str:
    buf = io.StringIO()
    _csv_rows(buf, columns, records)
    return buf.getvalue()


def _csv_writer(fh: IO[str], columns: Sequence[str]) -> csv.DictWriter[str]:
    w = csv.DictWriter(fh, fieldnames=list(columns), lineterminator="\n")
    w.writeheader()
    return w


def _csv_rows(fh: IO[str], columns: Sequence[str], records: Iterable[dict[str, Any]]) -> None:
    w = _csv_writer(fh, columns)
    for r in records:
        w.writerow(_csv_record(columns, r))


#: The widest ``_exact`` cell of a CSV table: a longer exact text (a float plant's 500-character
#: ``CRootOf``) is replaced by what kind of number it is; the JSON Lines and Parquet tables keep it whole.
CSV_EXACT_CAP = 64


def _csv_record(columns: Sequence[str], r: dict[str, Any]) -> dict[str, Any]:
    out = {k: ("" if r.get(k) is None else r.get(k)) for k in columns}
    for k in columns:
        v = out[k]
        if k.endswith("_exact") and isinstance(v, str) and len(v) > CSV_EXACT_CAP:
            out[k] = _exact_cell(v)
    return out


def _exact_cell(text: str) -> str:
    from .._numbers import kind_of

    return f"{kind_of(text)} (the exact text: JSON Lines or Parquet table)"


class TableWriter:
    """Write a sweep table row by row (records in index order) to ``path``, in the format its name asks for.

    Use as a context manager; :meth:`close` finishes the file (Parquet is
    written then, from the spool).  An exception inside the ``with`` leaves
    no table behind.
    """

    def __init__(self, path: str | Path, columns: Sequence[str]):
        self.fmt = format_of(path)
        self.path = Path(path)
        self.columns = list(columns)
        self.rows = 0
        if self.fmt == "parquet":
            _pyarrow()  # a missing pyarrow is said before any work
            fd, spool = tempfile.mkstemp(prefix=".kfio-sweep-", suffix=".jsonl", dir=self.path.parent or ".")
            self._spool = Path(spool)
            self._fh: IO[str] = os.fdopen(fd, "w", encoding="utf-8")
        else:
            self._fh = self.path.open("w", encoding="utf-8", newline="")
        # The header as csv.DictWriter writes it, then rows through the plain writer (the same bytes:
        # DictWriter only maps a record to its list of columns first).
        self._csv = _csv_writer(self._fh, self.columns).writer if self.fmt == "csv" else None
        self._exact_columns = [i for i, c in enumerate(self.columns) if c.endswith("_exact")]

    def write(self, record: dict[str, Any]) -> None:
        """Append one record (the next index)."""
        if self._csv is not None:
            row = ["" if (v := record.get(c)) is None else v for c in self.columns]
            for k in self._exact_columns:
                if isinstance(row[k], str) and len(row[k]) > CSV_EXACT_CAP:
                    row[k] = _exact_cell(row[k])
            self._csv.writerow(row)
        else:
            self._fh.write(jsonl_line({c: record.get(c) for c in self.columns}) + "\n")
        self.rows += 1

    def close(self) -> None:
        """Finish the file."""
        self._fh.close()
        if self.fmt == "parquet":
            try:
                _write_parquet(self.path, self.columns, self._spool)
            finally:
                self._spool.unlink(missing_ok=True)

    def abort(self) -> None:
        """Stop without a table (the sweep failed before its end)."""
        self._fh.close()
        if self.fmt == "parquet":
            self._spool.unlink(missing_ok=True)
        self.path.unlink(missing_ok=True)

    def __enter__(self) -> TableWriter:
        return self

    def __exit__(self, kind: Any, *rest: Any) -> None:
        if kind is None:
            self.close()
        else:
            self.abort()


def _pyarrow() -> Any:
    try:
        import pyarrow as pa
        import pyarrow.parquet  # noqa: F401 - the writer
    except ImportError:
        raise MissingDependency("pyarrow", "a Parquet table", "or write --out TABLE.csv") from None
    return pa


def _batches(spool: Path, columns: Sequence[str]) -> Iterator[dict[str, list[Any]]]:
    with spool.open(encoding="utf-8") as fh:
        batch: dict[str, list[Any]] = {c: [] for c in columns}
        n = 0
        for line in fh:
            r = json.loads(line)
            for c in columns:
                batch[c].append(r[c])
            n += 1
            if n == PARQUET_BATCH:
                yield batch
                batch, n = {c: [] for c in columns}, 0
        if n:
            yield batch


def _column_types(spool: Path, columns: Sequence[str]) -> dict[str, Any]:
    """Each column's Arrow type as :func:`pyarrow.array` infers it from the whole column.

    Per batch, inferred types that agree (or are ``null``) give the column's
    type; where batches disagree (integers in one, floats in another) the
    whole column is inferred at once.
    """
    pa = _pyarrow()
    seen: dict[str, set[Any]] = {c: set() for c in columns}
    for batch in _batches(spool, columns):
        for c in columns:
            seen[c].add(pa.array(batch[c]).type)
    types: dict[str, Any] = {}
    for c in columns:
        kinds = {t for t in seen[c] if t != pa.null()}
        if len(kinds) <= 1:
            types[c] = kinds.pop() if kinds else pa.null()
        else:  # mixed batches: infer from the whole column (this column only in memory)
            values = [v for batch in _batches(spool, [c]) for v in batch[c]]
            types[c] = pa.array(values).type
    return types


def _write_parquet(path: Path, columns: Sequence[str], spool: Path) -> None:
    pa = _pyarrow()
    import pyarrow.parquet as pq

    types = _column_types(spool, columns)
    schema = pa.schema([(c, types[c]) for c in columns])
    with pq.ParquetWriter(path, schema) as writer:
        for batch in _batches(spool, columns):
            writer.write_table(pa.table({c: pa.array(batch[c], type=types[c]) for c in columns}, schema=schema))


def write_table(path: str | Path, columns: Sequence[str], records: Iterable[dict[str, Any]]) -> str:
    """Write ``records`` (index order) to ``path`` in the format its name asks for; returns the format."""
    with TableWriter(path, columns) as w:
        for r in records:
            w.write(r)
    return w.fmt
