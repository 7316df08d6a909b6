"""``kfio bounds FILE [--json] [--grid K] [--horizon N] [--tolerance T]`` end to end (kfio.service.cli.main)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from kfio.service import exitcodes
from kfio.service.cli import main

from support.paths import ROOT

SCALAR = {"A": [[-1.25]], "C": [[1]], "Q": [[1]], "R": [[2.5]]}


def bernoulli(lam) -> dict:
    return {"model": "bernoulli", "arrival_probability": lam}


def two_sensors(sensors=None, channels=None) -> dict:
    return {
        "system": {
            "A": [[1.25, 0], [1, 1.1]],
            "C": [[1, 0], [1, 1]],
            "Q": [[20, 0], [0, 20]],
            "R": [[2.5, 0], [0, 2.5]],
            "sensors": sensors or [{"name": "gps", "rows": [0]}, {"name": "wheel", "rows": [1]}],
        },
        "channel": {"model": "per_sensor", "channels": channels or {"gps": bernoulli(0.5), "wheel": bernoulli(0.5)}},
    }


@pytest.fixture
def write(tmp_path: Path):
    def _write(obj, name="request.json") -> str:
        path = tmp_path / name
        path.write_text(obj if isinstance(obj, str) else json.dumps(obj))
        return str(path)

    return _write


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(["bounds", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_summary_and_exit_zero(write, capsys) -> None:
    code, out, err = run(capsys, write({"system": SCALAR, "channel": bernoulli(0.4)}), "--horizon", "2")
    assert code == exitcodes.STABLE and err == ""
    assert "0.36 (closed form) <= lambda_c <=" in out and "P_hat_N traces" in out


def test_json_and_flags(write, capsys) -> None:
    path = write(
        {"system": SCALAR, "channel": bernoulli(0.4), "options": {"bounds": {"horizon": 8, "tolerance": 1e-6}}}
    )
    code, out, _ = run(capsys, path, "--json", "--horizon", "4", "--tolerance", "1e-3")
    assert code == 0
    report = json.loads(out)
    assert [e["N"] for e in report["p_hat"]["entries"]] == [1, 2, 4]
    upper = report["critical_probability"]["upper"]
    assert upper["tolerance"] == 1e-3 and 0.36 < upper["value"] <= 0.361


@pytest.mark.slow
def test_examples_run(capsys) -> None:
    root = ROOT / "examples"
    for path in sorted(root.glob("bounds_*.json")):
        code, out, err = (
            run(capsys, str(path), "--json", "--horizon", "1")
            if "two_sensors" not in path.name
            else run(capsys, str(path), "--json", "--grid", "3")
        )
        assert code == 0, (path, err)
        json.loads(out)


def test_region_grid_flag(write, capsys) -> None:
    code, out, _ = run(capsys, write(two_sensors()), "--json", "--grid", "3")
    assert code == 0
    region = json.loads(out)["region"]
    assert region["values"] == [0.0, 0.5, 1.0] and len(region["labels"]) == 3
    code, out, _ = run(capsys, write(two_sensors()), "--grid", "3")
    assert "region map 3x3" in out


@pytest.mark.parametrize(
    "request_obj,argv,field",
    [
        ({"system": SCALAR, "channel": bernoulli(1.5)}, [], "/channel/arrival_probability"),
        (
            {"system": SCALAR, "channel": bernoulli(0.4), "options": {"bounds": {"arrival_probability": -1}}},
            [],
            "/options/bounds/arrival_probability",
        ),
        ({"system": SCALAR, "channel": bernoulli(0.4)}, ["--grid", "5"], "/options/bounds/grid"),
        ({"system": SCALAR, "channel": bernoulli(0.4)}, ["--horizon", "21"], "/options/bounds/horizon"),
        ({"system": SCALAR, "channel": bernoulli(0.4)}, ["--tolerance", "1"], "/options/bounds/tolerance"),
        (
            {"system": SCALAR, "channel": bernoulli(0.4)},
            ["--sdp-cross-check", "yes"],
            "/options/bounds/sdp_cross_check",
        ),
        (
            {"system": SCALAR, "channel": bernoulli(0.4), "options": {"bounds": {"sdp_cross_check": 1}}},
            [],
            "/options/bounds/sdp_cross_check",
        ),
        (
            {"system": SCALAR, "channel": bernoulli(0.4), "options": {"bounds": {"grid": 3, "colour": 1}}},
            [],
            "/options/bounds/colour",
        ),
        ({"system": {k: v for k, v in SCALAR.items() if k != "Q"}, "channel": bernoulli(0.4)}, [], "/system/Q"),
        (
            {"system": SCALAR, "channel": {"model": "gilbert_elliott", "failure_rate": 0.1, "recovery_rate": 0.5}},
            [],
            "/channel/model",
        ),
        (two_sensors(), ["--grid", "50"], "/options/bounds/grid"),
        (
            two_sensors(sensors=[{"name": "gps", "rows": [0]}, {"name": "wheel", "rows": [0]}]),
            [],
            "/system/sensors/1/rows/0",
        ),
        (two_sensors(sensors=[{"name": "gps", "rows": [0]}]), [], "/system/sensors"),
        (
            two_sensors(channels={"gps": bernoulli(0.5), "wheel": bernoulli(0.5), "lidar": bernoulli(0.5)}),
            [],
            "/channel/channels/lidar",
        ),
        (two_sensors(channels={"gps": bernoulli(0.5)}), [], "/channel/channels/wheel"),
    ],
)
def test_bad_input_exits_2_naming_the_field(write, capsys, request_obj, argv, field) -> None:
    code, out, err = run(capsys, write(request_obj), *argv)
    assert code == exitcodes.INVALID_INPUT
    assert out == ""
    assert err.startswith(f"kfio: invalid input at {field}:"), err
    assert len(err.strip().splitlines()) == 1


def test_unreadable_and_malformed_files_exit_2(write, capsys, tmp_path) -> None:
    code, _, err = run(capsys, str(tmp_path / "missing.json"))
    assert code == exitcodes.INVALID_INPUT and "cannot read" in err
    code, _, err = run(capsys, write("{not json"))
    assert code == exitcodes.INVALID_INPUT


def test_usage_error_exits_2(write, capsys) -> None:
    code, _, _ = run(capsys, write({"system": SCALAR, "channel": bernoulli(0.4)}), "--grid", "many")
    assert code == exitcodes.INVALID_INPUT


def test_time_budget_exits_4(write, capsys) -> None:
    three = {
        "A": [[1.25, 1, 0], [0, 0.9, 7], [0, 0, 0.6]],
        "C": [[1, 0, 2]],
        "Q": [[20, 0, 0], [0, 20, 0], [0, 0, 20]],
        "R": [[2.5]],
    }
    req = {"system": three, "channel": bernoulli(0.37), "options": {"time_budget_s": 0.01, "bounds": {"horizon": 12}}}
    code, _, err = run(capsys, write(req))
    assert code == exitcodes.BUDGET and "budget exceeded" in err
