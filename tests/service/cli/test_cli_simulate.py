"""``kfio simulate``: exit codes, flags overriding options, JSON report."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from kfio.service.cli import main

from support.paths import ROOT

REQUEST = {
    "system": {"A": [[-1.25]], "C": [[1]], "Q": [[1]], "R": [[2.5]]},
    "channel": {"model": "bernoulli", "arrival_probability": 0.5},
    "options": {"simulate": {"steps": 30, "trajectories": 400, "seed": 3}},
}


def write(tmp_path: Path, body: dict) -> str:
    path = tmp_path / "req.json"
    path.write_text(json.dumps(body))
    return str(path)


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_summary_and_exit_0(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(["simulate", write(tmp_path, REQUEST)], capsys)
    assert code == 0 and err == ""
    assert "Monte Carlo: 400 trajectories x 30 steps, seed 3" in out and "median" in out


def test_json_flags_override_options(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["simulate", write(tmp_path, REQUEST), "--json", "--steps", "12", "--trajectories", "50", "--seed", "9"]
    code, out, _ = run(argv, capsys)
    d = json.loads(out)
    assert code == 0 and (d["steps"], d["trajectories"], d["seed"]) == (12, 50, 9)
    assert len(d["mean_trace"]) == 13 and d["exact"] is None
    again = run(argv, capsys)[1]
    assert again == out  # same seed, same bytes


def test_exact_flag(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(["simulate", write(tmp_path, REQUEST), "--json", "--exact", "--steps", "8"], capsys)
    d = json.loads(out)
    assert code == 0 and d["exact"]["steps"] == 8 and d["exact"]["sequences"] == 256
    assert d["checks"]["exact_agreement"]["steps_compared"] == 9
    code, out, _ = run(["simulate", write(tmp_path, REQUEST), "--exact"], capsys)
    assert code == 0 and "exact E[P_t] (t <= 16)" in out  # default: 2^16 sequences, one packet


@pytest.mark.parametrize(
    ("argv", "body", "needle"),
    [
        (["--steps", "20000"], REQUEST, "/options/simulate/steps"),
        (["--trajectories", "1"], REQUEST, "/options/simulate/trajectories"),
        (["--steps", "1000", "--trajectories", "2000"], REQUEST, "exceeds the limit 1000000"),
        (["--seed", "-4"], REQUEST, "/options/simulate/seed"),
        (["--steps", "ten"], REQUEST, "kfio simulate"),  # argparse usage error
        ([], {**REQUEST, "options": {"simulate": {"exact_steps": 40}}}, "/options/simulate/exact_steps"),
        ([], {**REQUEST, "options": {"simulate": {"colour": "red"}}}, "/options/simulate/colour"),
        ([], {**REQUEST, "system": {"A": [[2]], "C": [[1]], "Q": [[1]]}}, "/system/R"),
    ],
)
def test_bad_input_exits_2(tmp_path: Path, capsys, argv: list[str], body: dict, needle: str) -> None:
    code, out, err = run(["simulate", write(tmp_path, body), *argv], capsys)
    assert code == 2 and out == ""
    assert needle in err and "Traceback" not in err


def test_unstable_overflow_still_exits_0_with_null_mean(tmp_path: Path, capsys) -> None:
    body = {**REQUEST, "system": {"A": [["1e40"]], "C": [[1]], "Q": [[1]], "R": [[1]]}}
    code, out, _ = run(["simulate", write(tmp_path, body), "--json"], capsys)
    d = json.loads(out)
    assert code == 0 and d["diverged"] is True and d["mean_trace"][-1] is None


def test_example_file_runs(capsys) -> None:
    example = ROOT / "examples" / "simulate_seed004_bernoulli.json"
    code, out, _ = run(["simulate", str(example), "--steps", "20", "--trajectories", "200"], capsys)
    assert code == 0 and "exact E[P_t] (t <= 12)" in out
