"""One table row per sweep point: its coordinates and the report's key fields.

The row is read off the same JSON report that ``kfio analyze|bounds|simulate|loop
--json`` prints (:meth:`to_dict`), so a sweep row and a single request agree by
construction; :func:`row_from_report` is the one place that says which fields
a row carries.
"""

from __future__ import annotations

from typing import Any, Mapping

#: The columns each command contributes, in table order (after index and coordinates).
FIELDS: dict[str, tuple[str, ...]] = {
    "analyze": (
        "verdict",
        "worst_rate",
        "critical_arrival_probability",
        "critical_arrival_probability_exact",
        "certified",
        "tail_exponent",
    ),
    "bounds": (
        "verdict_by_bounds",
        "lambda_lower",
        "lambda_upper",
        "trace_S_bar",
        "trace_V_bar",
    ),
    "loop": (
        "verdict",
        "spectral_radius",
        "cost",
        "cost_exact",
        "critical_sensor_arrival_probability",
        "critical_sensor_arrival_probability_exact",
        "critical_actuator_arrival_probability",
        "critical_actuator_arrival_probability_exact",
        "certified",
    ),
    "simulate": (
        "final_mean_trace",
        "final_p50_trace",
        "final_p99_trace",
        "diverged",
    ),
}


def coordinate_column(name: str) -> str:
    """The table column of the axis ``name``: ``axis:<name>``, a namespace no result field uses.

    An axis may be called anything (``index``, ``verdict``, ``error``...): its
    column never replaces a result's.
    """
    return f"axis:{name}"


def _dig(d: Any, *path: str) -> Any:
    for key in path:
        if not isinstance(d, Mapping):
            return None
        d = d.get(key)
    return d


def _last(seq: Any) -> Any:
    return seq[-1] if isinstance(seq, list) and seq else None


def row_from_report(command: str, report: Mapping[str, Any]) -> dict[str, Any]:
    """The key fields of one report (the dict of ``report.to_dict()``), with ``error`` empty."""
    return {**_fields(command, report), "error": None}


def _fields(command: str, report: Mapping[str, Any]) -> dict[str, Any]:
    if command == "analyze":
        rates = [b.get("rate") for b in report.get("blocks", []) if b.get("rate") is not None]
        tail = report.get("tail")
        return {
            "verdict": report.get("verdict"),
            "worst_rate": max(rates) if rates else None,
            "critical_arrival_probability": report.get("critical_arrival_probability"),
            "critical_arrival_probability_exact": report.get("critical_arrival_probability_exact"),
            "certified": all(b.get("certified", False) for b in report.get("blocks", [])),
            "tail_exponent": _dig(tail, "kappa"),
        }
    if command == "bounds":
        return {
            "verdict_by_bounds": _dig(report, "operating_point", "verdict_by_bounds"),
            "lambda_lower": _dig(report, "critical_probability", "lower", "value"),
            "lambda_upper": _dig(report, "critical_probability", "upper", "value"),
            "trace_S_bar": _dig(report, "covariance", "S_bar", "trace"),
            "trace_V_bar": _dig(report, "covariance", "V_bar", "trace"),
        }
    if command == "simulate":
        return {
            "final_mean_trace": _last(report.get("mean_trace")),
            "final_p50_trace": _last(_dig(report, "percentiles", "50")),
            "final_p99_trace": _last(_dig(report, "percentiles", "99")),
            "diverged": report.get("diverged"),
        }
    if command == "loop":
        return {key: report.get(key) for key in FIELDS["loop"]}
    raise ValueError(f"unknown command {command!r}")  # pragma: no cover - validated by parse_sweep


def _view(obj: Any) -> dict[str, Any]:
    """The JSON view of a report object (its fields, not yet encoded)."""
    from .._json import view_of

    view = view_of(type(obj))
    if view is None:  # pragma: no cover - every report part has a view (tests/test_json_views.py)
        raise TypeError(f"no JSON view for {type(obj).__qualname__}")
    return view(obj)


def analyze_row(report: Any) -> dict[str, Any]:
    """``row_from_report("analyze", report.to_dict())`` with only the row's fields encoded.

    A sweep row reads six fields of a report of a hundred values.  Each is
    taken from the same view and through the same encoder
    (:func:`kfio._json.encode`) as the whole report's JSON, so the
    row equals the one read off ``to_dict()`` (tested on every kind of
    channel in ``tests/sweep/test_sweep_plant_memo.py``).
    """
    from .._json import encode

    top = _view(report)
    blocks = []
    for block in top["blocks"]:
        fields = _view(block)
        blocks.append({"rate": encode(fields["rate"]), "certified": encode(fields["certified"])})
    tail = top["tail"]
    partial = {
        "verdict": encode(top["verdict"]),
        "blocks": blocks,
        "critical_arrival_probability": encode(top["critical_arrival_probability"]),
        "critical_arrival_probability_exact": encode(top["critical_arrival_probability_exact"]),
        "tail": None if tail is None else {"kappa": encode(_view(tail)["kappa"])},
    }
    return row_from_report("analyze", partial)


def error_row(command: str, kind: str, message: str) -> dict[str, Any]:
    """A row for a point that failed: every field empty, the error named."""
    row: dict[str, Any] = dict.fromkeys(FIELDS[command])
    row["error"] = f"{kind}: {message}"
    return row
