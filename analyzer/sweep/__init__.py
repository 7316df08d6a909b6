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

``kfio.sweep`` (the attribute of the package ``kfio``) is the typed function
:func:`sweep`; this subpackage stays importable under the same name
(``from kfio.sweep import run_sweep``).  Its names load on first use, so
importing it costs nothing until then (Dask and NumPy load with the run):
``kfio`` imports it at start-up to keep the function, not the subpackage, as
its attribute.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_names

#: Public name -> the private module (relative to this package) that defines it.
_LAZY = {
    "Axis": "._spec",
    "cache_stats": "._evaluate",
    "check_points": "._spec",
    "clear_caches": "._evaluate",
    "coordinate_column": "._rows",
    "coordinates_at": "._spec",
    "evaluate_point": "._evaluate",
    "exact_boundary": "._boundary",
    "FIELDS": "._rows",
    "format_of": "._table",
    "FORMATS": "._table",
    "in_index_order": "._engine",
    "iter_sweep": "._engine",
    "jsonl_line": "._table",
    "load_sweep": "._spec",
    "MAX_AXIS_VALUES": "._spec",
    "MAX_POINTS": "._spec",
    "MAX_SWEEP_FILE_BYTES": "._api",
    "parse_sweep": "._spec",
    "point_at": "._spec",
    "points": "._spec",
    "RationalRange": "._spec",
    "record": "._engine",
    "row_from_report": "._rows",
    "run_sweep": "._engine",
    "sweep": "._api",
    "sweep_size": "._spec",
    "sweep_spec": "._api",
    "SweepPointInvalid": "._spec",
    "SweepResult": "._engine",
    "SweepRow": "._engine",
    "SweepSpec": "._spec",
    "table_columns": "._engine",
    "TableWriter": "._table",
    "validate_points": "._spec",
    "write_table": "._table",
}

if TYPE_CHECKING:
    from ._api import MAX_SWEEP_FILE_BYTES, sweep, sweep_spec
    from ._boundary import exact_boundary
    from ._engine import SweepResult, SweepRow, in_index_order, iter_sweep, record, run_sweep, table_columns
    from ._evaluate import cache_stats, clear_caches, evaluate_point
    from ._rows import FIELDS, coordinate_column, row_from_report
    from ._spec import (
        MAX_AXIS_VALUES,
        MAX_POINTS,
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


__getattr__, __dir__ = lazy_names(__name__, _LAZY, globals())


__all__ = [
    "Axis",
    "FIELDS",
    "FORMATS",
    "MAX_AXIS_VALUES",
    "MAX_POINTS",
    "MAX_SWEEP_FILE_BYTES",
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
    "sweep",
    "sweep_size",
    "sweep_spec",
    "table_columns",
    "validate_points",
    "write_table",
]
