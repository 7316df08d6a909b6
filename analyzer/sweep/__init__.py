"""Sweeps and batches: one base request and axes (a grid or a zip), or a list of requests.

Every point is validated before any work starts; the eigenstructure is
derived once per plant; the points run serially or on Dask distributed (an
embedded LocalCluster by default, or an existing cluster).  Results are one
row per point (:mod:`kfio.sweep._rows`), as JSON Lines, CSV or Parquet.

Examples
--------
>>> from kfio.sweep import load_sweep, run_sweep
>>> spec = load_sweep('{"command": "analyze", '
...     '"base": {"system": {"A": [[2]], "C": [[1]]}, '
...     '"channel": {"model": "bernoulli", "arrival_probability": "1/2"}}, '
...     '"axes": [{"pointer": "/channel/arrival_probability", "from": "1/2", "to": "9/10", "num": 3}]}')
>>> spec.size
3
>>> [r.fields["verdict"] for r in run_sweep(spec, engine="serial").rows]
['unstable', 'unstable', 'stable']
"""

from ._boundary import exact_boundary
from ._engine import SweepResult, SweepRow, in_index_order, iter_sweep, record, run_sweep, table_columns
from ._evaluate import cache_stats, clear_caches, evaluate_point
from ._rows import FIELDS, coordinate_column, row_from_report
from ._spec import (
    Axis,
    RationalRange,
    SweepPointInvalid,
    SweepSpec,
    check_points,
    coordinates_at,
    load_sweep,
    parse_sweep,
    point_at,
    points,
    sweep_size,
    validate_points,
)
from ._table import FORMATS, TableWriter, format_of, jsonl_line, write_table

__all__ = [
    "Axis",
    "FIELDS",
    "FORMATS",
    "RationalRange",
    "SweepPointInvalid",
    "SweepResult",
    "SweepRow",
    "SweepSpec",
    "TableWriter",
    "cache_stats",
    "check_points",
    "clear_caches",
    "coordinate_column",
    "coordinates_at",
    "evaluate_point",
    "exact_boundary",
    "format_of",
    "in_index_order",
    "iter_sweep",
    "jsonl_line",
    "load_sweep",
    "parse_sweep",
    "point_at",
    "points",
    "record",
    "row_from_report",
    "run_sweep",
    "sweep_size",
    "table_columns",
    "validate_points",
    "write_table",
]
