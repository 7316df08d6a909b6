"""The CLI's budgets and memory limit hold even inside C calls.

No wall-clock assertions: a run either ends with the watchdog's exit 4 or it
does not; the subprocess timeouts here only guard against a hang.
"""

from __future__ import annotations

import json
import random
import subprocess
import sys
from pathlib import Path

import pytest

from kfio.service import exitcodes
from kfio.service.cli import main
from kfio.service.watchdog import run_supervised

from support.live_server import memory_request

SCALAR = {
    "system": {"A": [[2]], "C": [[1]], "Q": [[1]], "R": [[1]]},
    "channel": {"model": "bernoulli", "arrival_probability": 0.5},
}


def markov10_request() -> dict:
    """A 2x2 rotation with a Markov order-10 channel (1024 histories): minutes of work."""
    rng = random.Random(3)
    table = {format(h, "010b"): f"{rng.randint(1, 99)}/100" for h in range(1 << 10)}
    return {
        "system": {"A": [[0, "-6/5"], ["6/5", 0]], "C": [[1, 0]], "Q": [[1, 0], [0, 1]], "R": [[1]]},
        "channel": {"model": "markov", "order": 10, "arrival_probability": table},
    }


def big_power() -> int:
    return (7 ** (10**9)) & 1  # one C call of minutes that holds the GIL: no Python-level check runs


def test_watchdog_stops_a_c_call_that_never_checks_its_budget(capsys: pytest.CaptureFixture[str]) -> None:
    assert run_supervised(big_power, budget_s=0.2, grace_s=0.2) == exitcodes.BUDGET
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("kfio: budget exceeded")


def test_watchdog_passes_exit_code_and_output_through(capsys: pytest.CaptureFixture[str]) -> None:
    def work() -> int:
        print("x" * 200_000)  # more than a pipe holds
        print("note", file=sys.stderr)
        return 3

    assert run_supervised(work, budget_s=30) == 3
    out, err = capsys.readouterr()
    assert out == "x" * 200_000 + "\n" and err == "note\n"


def test_memory_limit_turns_a_huge_allocation_into_exit_4(capsys: pytest.CaptureFixture[str]) -> None:
    import numpy as np

    def hog() -> int:
        return int(np.ones((1 << 17, 1 << 14)).sum() > 0)  # 16 GiB

    assert run_supervised(hog, budget_s=60, memory_bytes=1 << 30) == exitcodes.BUDGET
    assert "memory budget exceeded" in capsys.readouterr().err


def test_internal_error_in_the_child_is_exit_70(capsys: pytest.CaptureFixture[str]) -> None:
    def bug() -> int:
        raise RuntimeError("boom")

    assert run_supervised(bug, budget_s=30) == exitcodes.INTERNAL
    assert "internal error" in capsys.readouterr().err


@pytest.mark.slow  # a subprocess that runs to its budget
def test_markov_order_10_stops_at_its_cli_budget(tmp_path: Path) -> None:
    path = tmp_path / "markov10.json"
    path.write_text(json.dumps(markov10_request()))
    r = subprocess.run(
        [sys.executable, "-m", "kfio.service.cli", "analyze", str(path), "--time-budget", "2"],
        capture_output=True,
        text=True,
        timeout=120,  # a hang guard only
    )
    assert r.returncode == exitcodes.BUDGET, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("kfio: budget exceeded"), r.stderr


@pytest.mark.slow  # a subprocess that runs to its memory limit
def test_cli_memory_limit_is_exit_4(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # Monte Carlo at the size limits needs more than 250 MiB (the CLI maps about 200 MiB after its
    # imports; the blocked simulation kernel needs between 300 and 350 MiB in all, the previous
    # one more than 400); see docs/service.md for the measured figures
    path = tmp_path / "slow.json"
    path.write_bytes(memory_request(time_budget_s=60))
    r = subprocess.run(
        [sys.executable, "-m", "kfio.service.cli", "simulate", str(path), "--memory-mb", "250"],
        capture_output=True,
        text=True,
        timeout=120,  # a hang guard only
    )
    assert r.returncode == exitcodes.BUDGET, r.stderr
    assert (
        r.stderr.strip()
        == "kfio: memory budget exceeded: the computation needs more than the limit of 250 MiB (--memory-mb)"
    )
    small = tmp_path / "scalar.json"
    small.write_text(json.dumps(SCALAR))
    assert main(["analyze", str(small), "--memory-mb", "0"]) == exitcodes.UNSTABLE  # 0: no limit


@pytest.mark.parametrize("flags", [["--time-budget", "0"], ["--time-budget", "1e-9"], ["--memory-mb", "-1"]])
def test_bad_budget_flags_are_invalid_input(
    tmp_path: Path, flags: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "scalar.json"
    path.write_text(json.dumps(SCALAR))
    assert main(["analyze", str(path), *flags]) == exitcodes.INVALID_INPUT
    assert capsys.readouterr().err.startswith("kfio: invalid input at --")


def test_request_budget_is_the_default_of_every_command(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # the request's own options.time_budget_s reaches the cooperative budget of simulate too
    body = {**SCALAR, "options": {"time_budget_s": 0.01, "simulate": {"steps": 1000, "trajectories": 1000}}}
    path = tmp_path / "sim.json"
    path.write_text(json.dumps(body))
    assert main(["simulate", str(path)]) == exitcodes.BUDGET
    assert "budget exceeded" in capsys.readouterr().err
