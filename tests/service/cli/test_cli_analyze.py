"""``kfio analyze``: exit codes, stable JSON, one clear message for bad input."""

from __future__ import annotations

import io
import json
import sys

import pytest

from kfio.service.cli import main

from support.paths import ROOT

EXAMPLES = ROOT / "examples"


def run_cli(argv, stdin=None, capsys=None, monkeypatch=None):
    if stdin is not None:
        monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(stdin.encode())))
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize(
    "example, code, verdict",
    [
        ("seed004_scalar.json", 0, "stable"),
        ("bounds_differ_2x2.json", 0, "stable"),
        ("seed001_gilbert_elliott.json", 1, "unstable"),
        ("boundary.json", 3, "boundary"),
        ("seed004_3x3.json", 0, "stable"),
    ],
)
def test_examples_exit_codes(example, code, verdict, capsys):
    c, out, err = run_cli(["analyze", "--json", str(EXAMPLES / example)], capsys=capsys)
    assert c == code and err == ""
    assert json.loads(out)["verdict"] == verdict


def test_summary_is_readable(capsys):
    c, out, _ = run_cli(["analyze", str(EXAMPLES / "bounds_differ_2x2.json")], capsys=capsys)
    assert c == 0 and "verdict: STABLE" in out and "critical arrival probability: 0.36 = 9/25" in out


def test_stdin(capsys, monkeypatch):
    body = '{"system": {"A": [[2]], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": 0.5}}'
    c, out, _ = run_cli(["analyze", "-"], stdin=body, capsys=capsys, monkeypatch=monkeypatch)
    assert c == 1 and "UNSTABLE" in out


@pytest.mark.parametrize(
    "body, field",
    [
        (
            '{"system": {"A": [[1, 2]], "C": [[1, 1]]}, "channel": {"model": "bernoulli", "arrival_probability": 0.5}}',
            "/system/A",
        ),
        (
            '{"system": {"A": [["__import__(\'os\').system(\'id\')"]], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": 0.5}}',
            "/system/A/0/0",
        ),
        (
            '{"system": {"A": [[2]], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": 1}}',
            "/channel/arrival_probability",
        ),
        (
            '{"system": {"A": [[2]], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": 0.5}, "extra": 1}',
            "/extra",
        ),
        ("not json", "/"),
    ],
)
def test_bad_input_exit_2_one_line(body, field, capsys, monkeypatch):
    c, out, err = run_cli(["analyze", "-"], stdin=body, capsys=capsys, monkeypatch=monkeypatch)
    assert c == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith(f"kfio: invalid input at {field}:") and "Traceback" not in err


def test_missing_file_and_usage(capsys, tmp_path):
    c, _, err = run_cli(["analyze", str(tmp_path / "nope.json")], capsys=capsys)
    assert c == 2 and "cannot read" in err
    assert main([]) == 2
    assert main(["analyze"]) == 2


def test_console_script_runs_as_a_process(tmp_path):
    import subprocess

    p = subprocess.run(
        [sys.executable, "-m", "kfio.service.cli", "analyze", str(EXAMPLES / "boundary.json")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert p.returncode == 3 and "BOUNDARY" in p.stdout


def test_budget_and_numerical_failures_have_their_own_exit_codes(capsys, monkeypatch):
    import kfio
    from kfio.errors import BudgetExceeded, NumericalFailure

    for exc, code, word in (
        (BudgetExceeded("sigma: more than 1 s"), 4, "budget exceeded"),
        (NumericalFailure("roots did not converge"), 5, "numerical failure"),
    ):

        def boom(*a, exc=exc, **k):
            raise exc

        monkeypatch.setattr(kfio, "analyze", boom)  # the command imports it when it runs
        c, out, err = run_cli(["analyze", str(EXAMPLES / "boundary.json")], capsys=capsys)
        assert c == code and out == "" and err.startswith(f"kfio: {word}:") and "Traceback" not in err
