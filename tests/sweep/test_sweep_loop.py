"""Sweeps over loop requests (``"command": "loop"``): rows are the loop report's, by CLI and HTTP.

The base is ``examples/loop_scalar.json`` (TCP-like scalar loop, fixed
gains).  Each row must equal :func:`kfio.loop.analyze_loop` on its own
point, and along the actuator axis the verdict must switch exactly at the
report's critical actuator arrival probability.
"""

from __future__ import annotations

import csv
import json
import time
from fractions import Fraction
from pathlib import Path

import httpx
import pytest

from kfio.loop import analyze_loop, parse_loop_request
from kfio.service.cli import main
from kfio.sweep import load_sweep, run_sweep
from kfio.sweep._spec import SweepPointInvalid, validate_points

from support.live_server import LiveServer

BASE = json.loads((Path(__file__).parents[2] / "examples" / "loop_scalar.json").read_text())
ACTUATOR = "/actuator_channel/arrival_probability"
SWEEP = {
    "command": "loop",
    "base": BASE,
    "axes": [
        {"pointer": "/channel/arrival_probability", "values": ["1/2", "4/5"], "name": "lambda"},
        {"pointer": ACTUATOR, "from": "2/5", "to": "1", "num": 4, "name": "nu"},
    ],
}


@pytest.fixture(scope="module")
def result():
    return run_sweep(load_sweep(json.dumps(SWEEP)), engine="serial")


def test_rows_are_the_loop_report_of_each_point(result) -> None:
    assert len(result.rows) == 8 and all(r.fields["error"] is None for r in result.rows)
    for row in result.rows:
        lam, nu = row.coordinates["lambda"], row.coordinates["nu"]
        tree = {
            **BASE,
            "channel": {"model": "bernoulli", "arrival_probability": lam},
            "actuator_channel": {"model": "bernoulli", "arrival_probability": nu},
        }
        report = analyze_loop(parse_loop_request(tree)).to_dict()
        for key, value in row.fields.items():
            if key != "error":
                assert value == report[key], (lam, nu, key)


def test_verdict_switches_at_the_exact_critical_values(result) -> None:
    for row in result.rows:
        lam, nu = Fraction(row.coordinates["lambda"]), Fraction(row.coordinates["nu"])
        f = row.fields
        crit_nu = f["critical_actuator_arrival_probability_exact"]
        crit_lam = f["critical_sensor_arrival_probability_exact"]
        # the fixed-gain estimator alone (a = 5/4, k = 1/2, c = 1): stable iff lam (a - k c)^2 + (1 - lam) a^2 < 1,
        # i.e. lam > 9/16; TCP-like, the loop's critical sensor probability is that value wherever nu stabilizes
        assert crit_lam is None or Fraction(crit_lam) == Fraction(9, 16)
        stable = lam > Fraction(9, 16) and crit_nu is not None and nu > Fraction(crit_nu)
        assert (f["verdict"] == "stable") == stable, (lam, nu)
        assert (f["cost"] is None) == (not stable)
    verdicts = {(r.coordinates["lambda"], r.coordinates["nu"]): r.fields["verdict"] for r in result.rows}
    assert verdicts[("4/5", "2/5")] == "unstable" and verdicts[("4/5", "1")] == "stable"  # both sides


def test_a_bad_loop_point_is_named_before_any_work() -> None:
    bad = {**SWEEP, "axes": [{"pointer": ACTUATOR, "values": ["1/2", "3/2"]}]}
    with pytest.raises(SweepPointInvalid) as err:
        validate_points(load_sweep(json.dumps(bad)))
    assert err.value.field == f"/points/1{ACTUATOR}"
    no_b = {**SWEEP, "base": {**BASE, "system": {k: v for k, v in BASE["system"].items() if k != "B"}}}
    with pytest.raises(SweepPointInvalid) as err:
        validate_points(load_sweep(json.dumps(no_b)))
    assert err.value.field.startswith("/points/0/system")


def test_cli_loop_sweep_writes_the_table_and_plot(tmp_path, capsys) -> None:
    spec, out, png = tmp_path / "s.json", tmp_path / "t.csv", tmp_path / "p.png"
    one_axis = {**SWEEP, "axes": [SWEEP["axes"][1]]}
    spec.write_text(json.dumps(one_axis))
    assert main(["sweep", str(spec), "--serial", "--quiet", "--out", str(out), "--plot", str(png)]) == 0
    rows = list(csv.DictReader(out.open()))
    assert [r["verdict"] for r in rows] == ["unstable", "stable", "stable", "stable"]
    assert {r["critical_actuator_arrival_probability_exact"] for r in rows} == {"75/152"}
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow
def test_http_loop_sweep_gives_the_cli_rows(result) -> None:
    with LiveServer(workers=1) as server:
        r = httpx.post(
            f"{server.url}/v1/sweeps",
            content=json.dumps(SWEEP),
            headers={"Content-Type": "application/json"},
            timeout=30,
        )
        assert r.status_code == 202, r.text
        for _ in range(600):  # bounded by count, not by the clock
            doc = httpx.get(server.url + r.headers["Location"], timeout=30).json()
            if doc["status"] in ("done", "failed", "cancelled"):
                break
            time.sleep(0.2)
        assert doc["status"] == "done", doc
        assert doc["result"]["rows"] == result.records()
