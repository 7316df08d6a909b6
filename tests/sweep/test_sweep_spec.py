"""Sweep requests: shape, exact ranges, pointers, up-front validation of every point."""

from __future__ import annotations

import json
from fractions import Fraction

import pytest

from kfio.errors import InvalidInput, LimitExceeded
from kfio.sweep import SweepPointInvalid, load_sweep, point_at, points, validate_points

BASE = {
    "system": {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]], "Q": [[20, 0], [0, 20]], "R": [[2.5]]},
    "channel": {"model": "bernoulli", "arrival_probability": 0.5},
}


def sweep(**kw):
    return load_sweep(json.dumps({"command": "analyze", "base": BASE, **kw}))


def test_range_axis_is_exact_rational_spacing():
    spec = sweep(axes=[{"pointer": "/channel/arrival_probability", "from": "3/10", "to": "9/10", "num": 61}])
    values = [Fraction(v) for v in spec.axes[0].values]
    assert values[0] == Fraction(3, 10) and values[-1] == Fraction(9, 10)
    assert all(b - a == Fraction(1, 100) for a, b in zip(values, values[1:]))


def test_grid_is_row_major_and_point_at_agrees_with_enumeration():
    spec = sweep(
        axes=[
            {"pointer": "/channel/arrival_probability", "values": ["1/2", "3/5", "7/10"]},
            {"pointer": "/system/A/0/0", "values": [1, 2]},
        ]
    )
    assert spec.size == 6
    listed = list(points(spec))
    assert [p.coordinates["/system/A/0/0"] for p in listed] == [1, 2, 1, 2, 1, 2]
    for p in listed:
        q = point_at(spec, p.index)
        assert q.request == p.request and q.coordinates == p.coordinates
    # the base request is not modified by substitution
    assert BASE["system"]["A"][0][0] == 1.25


def test_zip_pairs_values_and_needs_equal_lengths():
    spec = sweep(
        combine="zip",
        axes=[
            {"pointer": "/channel/arrival_probability", "values": ["1/2", "3/5"]},
            {"pointer": "/system/A/0/0", "values": [1, 2]},
        ],
    )
    assert [p.coordinates for p in points(spec)] == [
        {"/channel/arrival_probability": "1/2", "/system/A/0/0": 1},
        {"/channel/arrival_probability": "3/5", "/system/A/0/0": 2},
    ]
    with pytest.raises(InvalidInput, match="zip needs axes of equal length"):
        sweep(
            combine="zip",
            axes=[
                {"pointer": "/channel/arrival_probability", "values": ["1/2"]},
                {"pointer": "/system/A/0/0", "values": [1, 2]},
            ],
        )


@pytest.mark.parametrize(
    "axis, field, rule",
    [
        ({"pointer": "/channel/nope", "values": [1]}, "/axes/0/pointer", "nothing at /channel/nope"),
        ({"pointer": "/system/A/5/0", "values": [1]}, "/axes/0/pointer", "nothing at /system/A/5"),
        ({"pointer": "channel", "values": [1]}, "/axes/0/pointer", "starts with '/'"),
        ({"pointer": "/channel/arrival_probability"}, "/axes/0", "either 'values' or all of"),
        ({"pointer": "/channel/arrival_probability", "from": 0, "to": 1}, "/axes/0/num", "required"),
        ({"pointer": "/channel/arrival_probability", "values": []}, "/axes/0/values", "non-empty"),
        ({"pointer": "/channel/arrival_probability", "values": [1], "step": 2}, "/axes/0/step", "unknown key"),
    ],
)
def test_bad_axes_are_named(axis, field, rule):
    with pytest.raises(InvalidInput, match=rule) as info:
        sweep(axes=[axis])
    assert info.value.field == field


def test_huge_grids_are_refused_before_enumeration():
    axis = {"pointer": "/channel/arrival_probability", "from": "0.1", "to": "0.9", "num": 100000}
    with pytest.raises(LimitExceeded, match="at most 1000000"):
        sweep(axes=[axis, {**axis, "pointer": "/system/A/0/0"}])
    with pytest.raises(LimitExceeded):
        sweep(axes=[{**axis, "num": "1e999999999"}])


def test_every_point_is_validated_and_a_bad_one_is_named_by_index_and_pointer():
    spec = sweep(axes=[{"pointer": "/channel/arrival_probability", "values": ["1/2", "3/5", "7/5", "1/3"]}])
    with pytest.raises(SweepPointInvalid) as info:
        validate_points(spec)
    assert info.value.index == 2
    assert info.value.field == "/points/2/channel/arrival_probability"


def test_json_lines_of_requests_are_an_analyze_sweep():
    lines = "\n".join(json.dumps({**BASE, "system": {**BASE["system"], "A": [[a, 0], [1, 1.1]]}}) for a in (1.25, 2))
    spec = load_sweep(lines)
    assert spec.command == "analyze" and spec.size == 2 and spec.requests is not None
    assert len(validate_points(spec)) == 2


@pytest.mark.parametrize(
    "doc, field",
    [
        ({"command": "fly", "base": BASE}, "/command"),
        ({"command": "analyze"}, "/"),
        ({"command": "analyze", "base": BASE, "requests": [BASE]}, "/"),
        ({"command": "analyze", "base": BASE, "combine": "outer"}, "/combine"),
        ({"command": "analyze", "base": BASE, "options": {"point_budget_s": 0}}, "/options/point_budget_s"),
        ({"command": "analyze", "base": BASE, "options": {"colour": 1}}, "/options/colour"),
    ],
)
def test_bad_sweep_documents(doc, field):
    with pytest.raises(InvalidInput) as info:
        load_sweep(json.dumps(doc))
    assert info.value.field == field


def test_bytes_that_are_not_utf8_are_invalid_input():
    with pytest.raises(InvalidInput, match="not UTF-8"):
        load_sweep(b"\xf58\xefE\xa2")
