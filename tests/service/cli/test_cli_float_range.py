"""Floats derived from exact values never overflow silently.

Reproducer: ``A = [["1e160"]]`` gave exit 70 from ``kfio analyze --json``
(``Out of range float values are not JSON compliant: inf``), ``|alpha| = inf``
without ``--json``, and an ``OverflowError`` from ``kfio bounds``.
"""

from __future__ import annotations

import json
import math

import pytest

from kfio import analyze, load_request
from kfio.service.cli import main


def _body(a: str, sensors: bool = False) -> dict:
    body = {
        "system": {"A": [[a]], "C": [[1]], "Q": [[1]], "R": [[1]]},
        "channel": {"model": "bernoulli", "arrival_probability": 0.5},
    }
    if sensors:
        body["system"] = {
            "A": [[a, 0], [0, "3"]],
            "C": [[1, 0], [0, 1]],
            "Q": [[1, 0], [0, 1]],
            "R": [[1, 0], [0, 1]],
            "sensors": [{"name": "s1", "rows": [0]}, {"name": "s2", "rows": [1]}],
        }
        bern = {"model": "bernoulli", "arrival_probability": 0.5}
        body["channel"] = {"model": "per_sensor", "channels": {"s1": bern, "s2": bern}}
    return body


def _cli(tmp_path, capsys, *args: str, body: dict) -> tuple[int, str, str]:
    path = tmp_path / "r.json"
    path.write_text(json.dumps(body))
    code = main([*args, str(path)])
    out, err = capsys.readouterr()
    return code, out, err


def _finite_everywhere(tree) -> bool:
    if isinstance(tree, float):
        return math.isfinite(tree)
    if isinstance(tree, dict):
        return all(_finite_everywhere(v) for v in tree.values())
    if isinstance(tree, list):
        return all(_finite_everywhere(v) for v in tree)
    return True


def test_report_of_a_huge_modulus_is_valid_json_with_exact_text() -> None:
    rep = analyze(load_request(json.dumps(_body("1e160")))).to_dict()
    json.dumps(rep, allow_nan=False)  # raises on inf/NaN
    (b,) = rep["blocks"]
    assert b["modulus"] == 1e160 and b["modulus_exact"] == "1" + "0" * 160
    assert b["rate"] is None  # 10^320 / 2 is beyond float64: null, and the verdict is exact
    assert rep["verdict"] == "unstable"
    assert rep["critical_arrival_probability_exact"] == "9" * 320 + "/1" + "0" * 320


@pytest.mark.parametrize("a", ["1e160", "-1e199", "1e-199"])
def test_cli_analyze_both_outputs(tmp_path, capsys, a: str) -> None:
    code, out, err = _cli(tmp_path, capsys, "analyze", "--json", body=_body(a))
    assert code in (0, 1) and err == ""
    assert _finite_everywhere(json.loads(out))
    code, out, err = _cli(tmp_path, capsys, "analyze", body=_body(a))
    assert code in (0, 1) and err == ""
    assert "inf" not in out and "nan" not in out


def test_cli_analyze_two_sensors_with_a_huge_modulus(tmp_path, capsys) -> None:
    code, out, err = _cli(tmp_path, capsys, "analyze", "--json", body=_body("1e160", sensors=True))
    assert code == 1 and err == ""
    assert _finite_everywhere(json.loads(out))


def test_cli_bounds_refuses_entries_beyond_float_range_with_a_clear_limit(tmp_path, capsys) -> None:
    code, out, err = _cli(tmp_path, capsys, "bounds", "--json", body=_body("1e160"))
    assert code == 2 and out == ""
    assert err.startswith("kfio: invalid input at /system/A/0/0: the bounds are computed in floating point")


def test_cli_simulate_huge_entries_is_valid_json(tmp_path, capsys) -> None:
    body = _body("1e160")
    body["options"] = {"simulate": {"steps": 5, "trajectories": 20}}
    code, out, err = _cli(tmp_path, capsys, "simulate", "--json", body=body)
    assert code == 0 and "Traceback" not in err
    assert _finite_everywhere(json.loads(out))
