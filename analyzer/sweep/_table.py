"""Sweep tables: JSON Lines, CSV and Parquet (via pyarrow, the ``sweep`` extra)."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path
from typing import Any, Iterable, Sequence

from ..errors import InvalidInput, MissingDependency

FORMATS = ("csv", "parquet", "jsonl")


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
    w = csv.DictWriter(buf, fieldnames=list(columns), lineterminator="\n")
    w.writeheader()
    for r in records:
        w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in columns})
    return buf.getvalue()


def write_table(path: str | Path, columns: Sequence[str], records: list[dict[str, Any]]) -> str:
    """Write ``records`` to ``path`` in the format its name asks for; returns the format."""
    fmt = format_of(path)
    path = Path(path)
    if fmt == "csv":
        path.write_text(csv_text(columns, records), encoding="utf-8")
    elif fmt == "jsonl":
        path.write_text("".join(jsonl_line(r) + "\n" for r in records), encoding="utf-8")
    else:
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError:
            raise MissingDependency("pyarrow", "a Parquet table", "or write --out TABLE.csv") from None
        table = pa.table({c: [r.get(c) for r in records] for c in columns})
        pq.write_table(table, path)
    return fmt
