"""Sweeps stream: each distinct plant validated once, rows in index order, tables written as rows come."""

from __future__ import annotations

import json
import random

import pytest

from kfio.errors import InvalidInput
from kfio.model import parse_request
from kfio.sweep import (
    SweepRow,
    TableWriter,
    coordinates_at,
    in_index_order,
    load_sweep,
    point_at,
    points,
    run_sweep,
)
from kfio.sweep._parse import parse_point, system_cache

BASE = {
    "system": {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]], "Q": [[20, 0], [0, 20]], "R": [[2.5]]},
    "channel": {"model": "bernoulli", "arrival_probability": 0.5},
}


def _outcome(parse, tree):
    try:
        return ("ok", parse(tree))
    except InvalidInput as exc:
        return ("error", type(exc), exc.field, exc.rule)


def test_parse_point_gives_what_parse_request_gives_on_every_point_good_or_bad():
    # A[0][0] over four values (one makes Q's plant fine but the request bad elsewhere), times channels
    # with bad probabilities, a non-symmetric Q on one plant, and a string that reads as the same number.
    spec = load_sweep(
        json.dumps(
            {
                "command": "analyze",
                "base": BASE,
                "axes": [
                    {"pointer": "/system/Q/0/1", "values": [0, "0", 3]},  # 3: Q not symmetric
                    {"pointer": "/system/A/0/0", "values": [1.25, "5/4", "x", 2]},  # "x": not a number
                    {
                        "pointer": "/channel/arrival_probability",
                        "values": ["1/2", "3/2", 0.9],
                    },  # 3/2: not a probability
                ],
            }
        )
    )
    system_cache().clear()
    outcomes = [(_outcome(parse_point, p.request), _outcome(parse_request, p.request)) for p in points(spec)]
    for cached, direct in outcomes:
        assert cached == direct
    kinds = {o[0][0] for o in outcomes}
    assert kinds == {"ok", "error"}
    # plants that validated are shared: later points hit the cache (and a bad plant is never kept)
    # (6 plants validate: Q[0][1] in {0, "0"} x A[0][0] in {1.25, "5/4", 2}, each text its own key)
    assert system_cache().hits > 0 and len(system_cache().data) == 6


def test_parse_point_keeps_number_types_apart_in_its_key():
    # a sensor named "1" is valid, one named 1 (a number) is not: the cache must never confuse them
    good = {**BASE, "system": {**BASE["system"], "sensors": [{"name": "1", "rows": [0]}]}}
    bad = {**BASE, "system": {**BASE["system"], "sensors": [{"name": 1, "rows": [0]}]}}
    system_cache().clear()
    assert _outcome(parse_point, good) == _outcome(parse_request, good)
    assert _outcome(parse_point, bad) == _outcome(parse_request, bad)
    assert _outcome(parse_point, bad)[0] == "error"


def test_rows_come_back_in_index_order_whatever_order_they_finish_in():
    rows = [SweepRow(i, {}, {}) for i in range(200)]
    chunks = [rows[i : i + 16] for i in range(0, 200, 16)]
    random.Random(5).shuffle(chunks)
    shuffled = [r for c in chunks for r in c]
    assert [r.index for r in in_index_order(iter(shuffled))] == list(range(200))


def test_coordinates_at_agrees_with_point_at():
    spec = load_sweep(
        json.dumps(
            {
                "command": "analyze",
                "base": BASE,
                "axes": [
                    {"pointer": "/system/A/0/0", "name": "a", "values": [1.25, 2]},
                    {"pointer": "/channel/arrival_probability", "from": "1/2", "to": "9/10", "num": 5},
                ],
            }
        )
    )
    for i in range(spec.size):
        assert coordinates_at(spec, i) == point_at(spec, i).coordinates
    with pytest.raises(IndexError):
        coordinates_at(spec, spec.size)


@pytest.mark.parametrize("batch", [1, 3, 1000])
def test_parquet_streamed_in_row_groups_equals_the_whole_table_at_once(tmp_path, monkeypatch, batch):
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    from kfio.sweep import _table as table

    monkeypatch.setattr(table, "PARQUET_BATCH", batch)
    columns = ["index", "axis:x", "value", "flag", "error"]
    # column types that a batch alone would guess differently: ints then floats, nulls then text
    records = [
        {
            "index": i,
            "axis:x": [1, "3/2", None][i % 3],
            "value": i if i < 4 else i / 2,
            "flag": i % 2 == 0,
            "error": None,
        }
        for i in range(7)
    ]
    records[5]["error"] = "numerical-failure: x"
    mixed = [r["axis:x"] for r in records]
    with pytest.raises(pa.ArrowInvalid):  # what pyarrow says about a column of ints and texts ...
        pa.array(mixed)
    for r in records:
        r["axis:x"] = str(r["axis:x"])  # ... so the coordinates are texts, as the sweep's JSON view makes them
    with TableWriter(tmp_path / "s.parquet", columns) as w:
        for r in records:
            w.write(r)
    whole = pa.table({c: [r[c] for r in records] for c in columns})
    got = pq.read_table(tmp_path / "s.parquet")
    assert got.schema == whole.schema and got.equals(whole)
    assert not list(tmp_path.glob(".kfio-sweep-*"))  # the spool is gone


def test_a_failed_sweep_leaves_no_table(tmp_path):
    path = tmp_path / "t.csv"
    with pytest.raises(RuntimeError):
        with TableWriter(path, ["index"]) as w:
            w.write({"index": 0})
            raise RuntimeError("stopped")
    assert not path.exists()


def test_streamed_tables_equal_the_sweeps_records(tmp_path):
    from kfio.service.cli import main

    doc = {
        "command": "analyze",
        "base": BASE,
        "axes": [
            {"pointer": "/system/A/0/0", "name": "a", "values": [1.25, 2]},
            {"pointer": "/channel/arrival_probability", "from": "1/2", "to": "9/10", "num": 5},
        ],
        "options": {"chunk_size": 3},
    }
    path = tmp_path / "s.json"
    path.write_text(json.dumps(doc))
    records = run_sweep(load_sweep(path.read_text()), engine="serial").records()
    out = tmp_path / "t.jsonl"
    assert main(["sweep", str(path), "--serial", "--quiet", "--out", str(out)]) == 0
    assert [json.loads(line) for line in out.read_text().splitlines()] == records


def test_range_values_in_integers_equal_the_exact_formula():
    from fractions import Fraction

    from kfio.model import fraction_text
    from kfio.sweep import RationalRange

    rng = random.Random(11)
    for _ in range(300):
        lo = Fraction(rng.randint(-(10**6), 10**6), rng.randint(1, 10**4))
        hi = Fraction(rng.randint(-(10**6), 10**6), rng.randint(1, 10**4))
        num = rng.randint(1, 40)
        hi = lo if num == 1 else hi
        r = RationalRange(lo, hi, num)
        assert list(r) == [fraction_text(lo + (hi - lo) * Fraction(i, max(1, num - 1))) for i in range(num)]
        assert r[-1] == fraction_text(hi)
