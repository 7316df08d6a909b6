"""Sweeps are sized from their axes before anything is built, and validated in workers.

Reproducers: 150 axes of ``num: 100000`` (12.8 KB) once cost minutes of server
CPU and a gigabyte before a 422; a sweep of more than 10^4300 points was a 500
(Python refuses to print such an int); every point was validated in a thread
of the server.  Each test asserts behaviour (what is built, what is answered,
where validation runs), never time.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient

from kfio.errors import LimitExceeded
from kfio.service.cli import main
from kfio.service.settings import Settings
from kfio.sweep import RationalRange, load_sweep, parse_sweep, sweep_size
from kfio.sweep import _spec as spec_module

from support.app_client import ready_client

BASE = {
    "system": {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]], "Q": [[20, 0], [0, 20]], "R": [[2.5]]},
    "channel": {"model": "bernoulli", "arrival_probability": 0.5},
}
PROBLEM = "application/problem+json"


def wide(n_axes: int, num: int = 100_000) -> dict[str, Any]:
    """``n_axes`` range axes of ``num`` values each, all on the same pointer (names differ)."""
    axis = {"pointer": "/channel/arrival_probability", "from": "1/10", "to": "9/10", "num": num}
    return {"command": "analyze", "base": BASE, "axes": [{**axis, "name": f"p{i}"} for i in range(n_axes)]}


@pytest.fixture
def built(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """Every axis value the sweep code makes (each goes through ``fraction_text``)."""
    made: list[Any] = []
    real = spec_module.fraction_text

    def spy(x: Any) -> str:
        made.append(x)
        return real(x)

    monkeypatch.setattr(spec_module, "fraction_text", spy)
    return made


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    settings = Settings(workers=1, job_workers=1, max_jobs=4, time_budget_s=30)
    with ready_client(settings) as c:
        yield c


def post_sweep(client: TestClient, doc: Any) -> Any:
    return client.post("/v1/sweeps", content=json.dumps(doc), headers={"content-type": "application/json"})


def test_the_size_of_a_grid_is_the_product_of_its_axes_lengths_computed_without_building_them(built):
    pointer = "/channel/arrival_probability"
    listed = {"pointer": pointer, "values": [0.5, 0.6, 0.7], "name": "b"}
    doc = {"base": BASE, "axes": [{"pointer": pointer, "from": "0", "to": "1", "num": 7, "name": "a"}, listed]}
    assert sweep_size(doc) == 21 == load_sweep(json.dumps(doc)).size
    assert sweep_size({**doc, "combine": "zip", "axes": [listed, {**listed, "name": "c"}]}) == 3
    assert sweep_size({"requests": [BASE] * 5}) == 5
    assert built == []  # nothing was made: the counts come from num and len(values)


def test_a_range_axis_is_held_as_three_numbers_and_agrees_with_explicit_spacing(built):
    spec = parse_sweep(wide(1, 9))
    values = spec.axes[0].values
    assert isinstance(values, RationalRange) and len(values) == 9 and built == []
    # brute force: from + (to - from) i / (num - 1), i = 0..8, as exact fractions
    from fractions import Fraction

    expected = [Fraction(1, 10) + Fraction(8, 10) * i / 8 for i in range(9)]
    assert [Fraction(v) for v in values] == expected
    assert values[-1] == values[8] == "9/10" and values[1:3] == (values[1], values[2])


def test_150_axes_of_100000_values_are_refused_without_building_an_axis(built):
    with pytest.raises(LimitExceeded) as err:
        parse_sweep(wide(150))
    assert err.value.field == "/axes"
    assert "more than 10^" in err.value.rule and built == []


def test_a_sweep_of_more_than_10_to_the_4300_points_is_refused_with_a_power_of_ten():
    doc = wide(861)  # 100000^861 = 10^4305 points
    with pytest.raises(LimitExceeded) as err:
        parse_sweep(doc)
    assert "more than 10^4304 points" in err.value.rule  # 10^4304 < 10^4305: true, and short
    assert len(str(err.value)) < 200


def test_the_size_message_is_exact_below_the_limits_magnitude():
    with pytest.raises(LimitExceeded, match="more than 1000 points; at most 1000"):
        sweep_size(wide(2, 40), limit=1000)
    with pytest.raises(LimitExceeded, match="the sweep has 1001 points; at most 1000"):
        sweep_size({"requests": [BASE] * 1001}, limit=1000)


def test_http_refuses_the_150_axis_body_with_422_inside_the_request(client, built):
    r = post_sweep(client, wide(150))
    assert r.status_code == 422 and r.headers["content-type"] == PROBLEM, r.text
    assert r.json()["field"] == "/axes" and "more than 10^" in r.json()["detail"]
    assert built == []  # the server made no axis value


def test_http_refuses_10_to_the_4305_points_with_422_not_500(client):
    r = post_sweep(client, wide(861))
    assert r.status_code == 422 and r.headers["content-type"] == PROBLEM, r.text
    assert "10^4304" in r.json()["detail"] and "sys.set_int_max_str_digits" not in r.text


def test_http_refuses_2_to_the_14300_points_of_listed_values_with_422_not_500(client):
    from support.hostile import values_sweep

    r = client.post("/v1/sweeps", content=values_sweep(14_300), headers={"content-type": "application/json"})
    assert r.status_code == 422 and r.headers["content-type"] == PROBLEM, r.text
    assert "more than 10^4304 points" in r.json()["detail"]  # 2^14300 = 1.1 * 10^4304


def test_http_counts_points_against_the_deployments_limit(client):
    r = post_sweep(client, wide(2, 1000))  # 10^6 points; this deployment's default is 10^5
    assert r.status_code == 422 and "at most 100000" in r.json()["detail"], r.text


def test_the_server_validates_no_point_the_worker_does(client, monkeypatch):
    """A bad point is not looked at in the server process: the job's worker names it in the job's problem."""
    from kfio.sweep import _parse as server_side  # where the sweep calls the single-request validator

    def forbidden(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("a sweep's point was validated in the server process")

    monkeypatch.setattr(server_side, "parse_request", forbidden)
    doc = {**wide(1, 3), "axes": [{"pointer": "/channel/arrival_probability", "values": ["1/2", "1/3", "2"]}]}
    r = post_sweep(client, doc)
    assert r.status_code == 202, r.text
    location = r.headers["location"]
    deadline = time.monotonic() + 120
    while (doc := client.get(location).json())["status"] not in ("done", "failed", "cancelled"):
        assert time.monotonic() < deadline, doc
        time.sleep(0.05)
    assert doc["status"] == "failed" and doc["problem"]["status"] == 422, doc
    assert doc["problem"]["field"] == "/points/2/channel/arrival_probability"


@pytest.mark.parametrize("n_axes", [150, 861])
def test_kfio_sweep_refuses_huge_grids_with_exit_2_before_building(tmp_path, capsys, built, n_axes):
    path = tmp_path / "sweep.json"
    path.write_text(json.dumps(wide(n_axes)))
    assert main(["sweep", str(path), "--serial"]) == 2
    err = capsys.readouterr().err
    assert "/axes" in err and "more than 10^" in err and "Traceback" not in err
    assert built == []


COLLIDING = {
    "command": "analyze",
    "base": BASE,
    "axes": [
        {"pointer": "/channel/arrival_probability", "name": "index", "values": ["3/10", "9/10"]},
        {"pointer": "/system/Q/0/0", "name": "verdict", "values": [20]},
        {"pointer": "/system/R/0/0", "name": "error", "values": ["5/2"]},
    ],
}


def _check_table(columns: list[str], records: list[dict[str, Any]]) -> None:
    assert len(set(columns)) == len(columns)
    assert columns[:4] == ["index", "axis:index", "axis:verdict", "axis:error"]
    assert [r["index"] for r in records] == [0, 1]
    assert [r["axis:index"] for r in records] == ["3/10", "9/10"]
    assert [r["axis:verdict"] for r in records] == [20, 20] and [r["axis:error"] for r in records] == ["5/2"] * 2
    assert [r["verdict"] for r in records] == ["unstable", "stable"]  # lambda_c = 9/25 (Sinopoli et al. 2004)
    assert [r["error"] for r in records] == [None, None]


def test_axes_named_like_result_columns_keep_their_own_columns_in_every_format(tmp_path, capsys):
    import csv

    import pyarrow.parquet as pq

    from kfio.sweep import run_sweep, write_table

    result = run_sweep(parse_sweep(COLLIDING), engine="serial")
    _check_table(result.columns, result.records())
    for name in ("t.csv", "t.jsonl", "t.parquet"):
        write_table(tmp_path / name, result.columns, result.records())
    with open(tmp_path / "t.csv", newline="") as fh:
        reader = csv.reader(fh)
        header = next(reader)
        assert header == result.columns and len(set(header)) == len(header)
        assert [row[1] for row in reader] == ["3/10", "9/10"]
    lines = [json.loads(line) for line in (tmp_path / "t.jsonl").read_text().splitlines()]
    _check_table(list(lines[0]), lines)
    table = pq.read_table(tmp_path / "t.parquet")
    assert table.column_names == result.columns
    assert table.column("axis:index").to_pylist() == ["3/10", "9/10"] and table.column("index").to_pylist() == [0, 1]
    # the CLI streams the same rows
    path = tmp_path / "sweep.json"
    path.write_text(json.dumps(COLLIDING))
    assert main(["sweep", str(path), "--serial"]) == 0
    streamed = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    _check_table(list(streamed[0]), streamed)


def test_http_table_keeps_axes_named_like_result_columns_apart(client):
    r = post_sweep(client, COLLIDING)
    assert r.status_code == 202, r.text
    location = r.headers["location"]
    deadline = time.monotonic() + 120
    while (doc := client.get(location).json())["status"] not in ("done", "failed", "cancelled"):
        assert time.monotonic() < deadline, doc
        time.sleep(0.05)
    assert doc["status"] == "done", doc
    _check_table(doc["result"]["columns"], doc["result"]["rows"])


def _wait(client: TestClient, location: str) -> dict[str, Any]:
    deadline = time.monotonic() + 120
    while (doc := client.get(location).json())["status"] not in ("done", "failed", "cancelled"):
        assert time.monotonic() < deadline, doc
        time.sleep(0.05)
    return doc


def test_json_lines_of_requests_are_a_sweep_over_http_as_for_the_cli(client, tmp_path, capsys):
    """A body of JSON lines is a sweep for the job store too, never re-parsed as one JSON document and refused."""
    variants = [{**BASE, "system": {**BASE["system"], "A": [[a, 0], [1, 1.1]]}} for a in (1.25, 2)]
    text = "\n".join(json.dumps(v) for v in variants) + "\n"
    r = client.post("/v1/sweeps", content=text, headers={"content-type": "application/json"})
    assert r.status_code == 202, r.text
    doc = _wait(client, r.headers["location"])
    assert doc["status"] == "done", doc
    rows = doc["result"]["rows"]
    path = tmp_path / "variants.jsonl"
    path.write_text(text)
    assert main(["sweep", str(path), "--serial"]) == 0
    assert rows == [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    # brute force: each row is the single request's verdict
    for row, variant in zip(rows, variants):
        single = client.post("/v1/analyze", json=variant).json()
        assert row["verdict"] == single["verdict"]


def test_point_validation_checks_in_with_its_budget_after_every_point_and_stops_when_it_is_spent():
    from kfio import Budget
    from kfio.errors import BudgetExceeded
    from kfio.sweep._spec import check_points

    spec = parse_sweep(wide(1, 50))
    ticks: list[int] = []
    assert check_points(spec, tick=lambda: ticks.append(1)) == 50 and len(ticks) == 50
    budget = Budget(max_steps=10)
    with pytest.raises(BudgetExceeded):
        check_points(spec, tick=lambda: budget.tick("validating the sweep's points"))
    assert budget.steps == 11  # stopped at the first check-in past the budget, not at the end
