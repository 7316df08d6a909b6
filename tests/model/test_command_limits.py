"""Per-command state limits: ``analyze`` accepts up to 120 states, every other command 40.

The exact verdict of a dense n = 120 plant takes seconds (docs/speed.md); ``bounds``
solves Stein equations in ``n(n+1)/2`` unknowns and keeps the old limit.  Each door
validates with the limits of the command it runs (:meth:`kfio.Limits.for_command`).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import kfio
from kfio import DEFAULT_LIMITS, LimitExceeded, Limits, load_request
from kfio.service.cli import main as cli_main
from kfio.service.settings import Settings

N = 60  # above the general limit, below analyze's


def plant(n: int) -> dict:
    A = [["1/2" if i == j else 0 for j in range(n)] for i in range(n)]
    A[0][0] = "6/5"  # one unstable mode, seen by the single output: lambda_c = 1 - 1/(6/5)^2 = 11/36
    return {
        "system": {"A": A, "C": [[1] * n], "Q": np.eye(n, dtype=int).tolist(), "R": [[1]]},
        "channel": {"model": "bernoulli", "arrival_probability": "1/2"},
    }


def test_for_command_raises_only_the_analyze_state_limit() -> None:
    assert DEFAULT_LIMITS.for_command("analyze").max_states == 120
    for command in ("bounds", "simulate", "loop", None):
        assert DEFAULT_LIMITS.for_command(command) == DEFAULT_LIMITS
    small = Limits(max_states=30, max_analyze_states=20)  # a deployment may make analyze's the smaller: never below
    assert small.for_command("analyze").max_states == 30
    assert Settings(max_analyze_states=60).limits("analyze").max_states == 60
    assert Settings(max_analyze_states=60).limits("bounds").max_states == 40


def test_a_large_request_is_refused_naming_both_limits_unless_it_is_for_analyze() -> None:
    text = json.dumps(plant(N))
    with pytest.raises(
        LimitExceeded, match=rf"A has {N} rows; the limit is 40 \(kfio analyze accepts up to 120 states\)"
    ):
        load_request(text)
    request = load_request(text, DEFAULT_LIMITS.for_command("analyze"))
    assert len(request.system.A) == N
    with pytest.raises(LimitExceeded, match=r"A has 121 rows; the limit is 120$"):
        load_request(json.dumps(plant(121)), DEFAULT_LIMITS.for_command("analyze"))
    with pytest.raises(LimitExceeded, match=r"A has 61 rows; the limit is 60$"):
        load_request(json.dumps(plant(61)), Settings(max_analyze_states=60).limits("analyze"))


def test_cli_analyze_decides_it_and_bounds_refuses_it_with_exit_2(tmp_path: Path, capsys) -> None:
    path = tmp_path / "big.json"
    path.write_text(json.dumps(plant(N)))
    assert cli_main(["analyze", str(path), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["verdict"] == "stable" and report["critical_arrival_probability_exact"] == "11/36"
    assert cli_main(["bounds", str(path)]) == 2
    assert "A has 60 rows; the limit is 40 (kfio analyze accepts up to 120 states)" in capsys.readouterr().err


def test_python_api_builds_a_large_system_for_analyze_only() -> None:
    tree = plant(N)["system"]
    system = kfio.System(A=tree["A"], C=tree["C"], Q=tree["Q"], R=tree["R"])
    assert kfio.analyze(system, kfio.bernoulli("1/2")).critical_arrival_probability_exact == "11/36"
    with pytest.raises(LimitExceeded) as info:
        kfio.bounds(system, kfio.bernoulli("1/2"))
    assert info.value.field == "system.A" and "kfio analyze accepts up to 120 states" in info.value.rule
    with pytest.raises(LimitExceeded, match=r"^A: A has 121 rows; the limit is 120$"):
        kfio.System(A=np.eye(121), C=np.ones((1, 121)))
