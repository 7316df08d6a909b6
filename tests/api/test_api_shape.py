"""One shape for the public functions: kfio.sweep and kfio.check answer as their files do, every
function takes ``budget``, a python-control StateSpace gives the System's report, bad arguments are named."""

from __future__ import annotations

import inspect
import json
import time
from fractions import Fraction
from pathlib import Path

import control
import pytest

import kfio
from kfio.check import load_check, run_check
from kfio.service.cli import main
from kfio.sweep import load_sweep, run_sweep

from support.paths import ROOT

SWEEP = ROOT / "examples" / "sweeps" / "arrival_probability.json"
CHECK = ROOT / "examples" / "check" / "kfio-check.json"
PUBLIC = ("analyze", "bounds", "simulate", "expected_covariance", "loop", "fit", "sweep", "check")


def test_every_public_function_is_a_function_with_a_budget_keyword() -> None:
    for name in PUBLIC:
        fn = getattr(kfio, name)
        assert inspect.isfunction(fn), name
        param = inspect.signature(fn).parameters["budget"]
        assert param.kind is inspect.Parameter.KEYWORD_ONLY and param.default is None, name


def test_the_subpackages_stay_importable_under_the_functions_names() -> None:
    from kfio.check import CheckSpec
    from kfio.sweep import SweepSpec

    assert callable(kfio.sweep) and callable(kfio.check)
    assert kfio.sweep.__module__ == "kfio.sweep._api" and kfio.check.__module__ == "kfio.check._api"
    assert SweepSpec.__name__ == "SweepSpec" and CheckSpec.__name__ == "CheckSpec"


def _rows(result: kfio.SweepResult) -> list[tuple[int, dict[str, object], dict[str, object]]]:
    return [(r.index, r.coordinates, r.fields) for r in result.rows]


def test_sweep_answers_as_run_sweep_from_a_path_a_tree_and_a_spec() -> None:
    expected = _rows(run_sweep(load_sweep(SWEEP.read_bytes()), engine="serial"))
    tree = json.loads(SWEEP.read_text())
    for spec in (SWEEP, str(SWEEP), tree, load_sweep(SWEEP.read_bytes())):
        assert _rows(kfio.sweep(spec, engine="serial")) == expected
    # the exact critical probability of the plant, 9/25, and the verdict at each point beside it
    result = kfio.sweep(tree, engine="serial")
    for row in result.rows:
        p = Fraction(row.coordinates["arrival_probability"])
        assert row.exact_of("critical_arrival_probability") == Fraction(9, 25)
        assert row.fields["verdict"] == ("stable" if p > Fraction(9, 25) else "unstable")


def test_sweep_rows_equal_the_cli_table(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "rows.jsonl"
    assert main(["sweep", str(SWEEP), "--serial", "--quiet", "--out", str(out)]) == 0
    cli = [json.loads(line) for line in out.read_text().splitlines()]
    ours = kfio.sweep(SWEEP, engine="serial").records()
    assert [{k: v for k, v in r.items()} for r in ours] == cli


def test_sweep_budget_stops_the_points_not_done() -> None:
    tree = json.loads(SWEEP.read_text())
    done = kfio.Budget(seconds=0.01)
    time.sleep(0.02)  # a budget already spent: no point may start
    result = kfio.sweep(tree, engine="serial", budget=done)
    assert result.stopped == "budget-exceeded" or all("budget-exceeded" in str(r.fields) for r in result.rows)
    assert all(r.fields.get("verdict") is None for r in result.rows)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"engine": "threads"}, "engine"),
        ({"workers": 0}, "workers"),
        ({"chunk_size": -1}, "chunk_size"),
        ({"budget": 0}, "budget"),
        ({"budget": "soon"}, "budget"),
    ],
)
def test_sweep_names_a_bad_argument(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(kfio.InvalidInput) as exc:
        kfio.sweep(SWEEP, **kwargs)  # type: ignore[arg-type]
    assert exc.value.field == field


def test_sweep_names_a_bad_spec() -> None:
    with pytest.raises(kfio.InvalidInput) as exc:
        kfio.sweep(42)  # type: ignore[arg-type]
    assert exc.value.field == "spec"
    with pytest.raises(kfio.InvalidInput) as exc:
        kfio.sweep(ROOT / "no-such-sweep.json")
    assert exc.value.field == "spec"


def _outcomes(result: kfio.CheckResult) -> list[dict[str, object]]:
    return [{k: v for k, v in o.to_dict().items() if k != "seconds"} for o in result.outcomes]


def test_check_answers_as_run_check_and_the_cli(capsys: pytest.CaptureFixture[str]) -> None:
    expected = _outcomes(run_check(load_check(CHECK), workers=1))
    assert _outcomes(kfio.check(CHECK, workers=1)) == expected
    tree = json.loads(CHECK.read_text())
    assert _outcomes(kfio.check(tree, base=CHECK.parent, workers=1)) == expected
    assert _outcomes(kfio.check(load_check(CHECK), workers=1)) == expected
    assert main(["check", str(CHECK), "--json", "--workers", "1"]) == 0
    cli = json.loads(capsys.readouterr().out)
    assert [{k: v for k, v in o.items() if k != "seconds"} for o in cli["outcomes"]] == expected


def test_check_outcomes_give_exact_values(tmp_path: Path) -> None:
    (tmp_path / "plant.json").write_text(json.dumps({"system": {"A": [[-1.25]], "C": [[1]]}}))
    (tmp_path / "radio.json").write_text(json.dumps({"model": "bernoulli", "arrival_probability": "1/2"}))
    tree = {
        "checks": [
            {
                "name": "scalar",
                "plant": "plant.json",
                "channel": "radio.json",
                "requirements": {"verdict": "stable", "margin": "1/10", "critical_arrival_probability_at_most": "2/5"},
            }
        ]
    }
    result = kfio.check(tree, base=tmp_path, workers=1)
    verdict, margin, critical = result.outcomes
    # |a|^2 = 25/16, sigma = 1/2 (one packet lost with probability 1/2): worst rate 25/32; lambda_c = 1 - 1/|a|^2
    assert margin.exact_of("measured") == Fraction(25, 32) and margin.exact_of("required") == Fraction(1, 10)
    assert critical.exact_of("measured") == Fraction(9, 25) and critical.exact_of("required") == Fraction(2, 5)
    assert verdict.exact_of("measured") is None and verdict.exact_of("required") is None


def test_check_keeps_its_paths_confined(tmp_path: Path) -> None:
    inside, outside = tmp_path / "inside", tmp_path / "outside"
    inside.mkdir()
    outside.mkdir()
    (outside / "plant.json").write_text(json.dumps({"system": {"A": [[-1.25]], "C": [[1]]}}))
    (inside / "radio.json").write_text(json.dumps({"model": "bernoulli", "arrival_probability": "1/2"}))
    tree = {"checks": [{"name": "e", "plant": "../outside/plant.json", "channel": "radio.json",
                        "requirements": {"verdict": "stable"}}]}  # fmt: skip
    with pytest.raises(kfio.InvalidInput) as exc:
        kfio.check(tree, base=inside, workers=1)
    assert exc.value.field.startswith("/checks/0/plant")
    assert kfio.check(tree, base=inside, allow_outside=[outside], workers=1).status == "pass"


def test_check_budget_marks_the_runs_not_done() -> None:
    spent = kfio.Budget(seconds=0.01)
    time.sleep(0.02)
    result = kfio.check(CHECK, workers=1, budget=spent)
    assert result.status == "budget"
    assert {o.error_kind for o in result.outcomes} == {"budget-exceeded"}


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"workers": 0}, "workers"),
        ({"budget": 10**6}, "budget"),
        ({"base": "."}, "base"),
        ({"allow_outside": ["/no/such/dir"]}, "allow_outside"),
    ],
)
def test_check_names_a_bad_argument(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(kfio.InvalidInput) as exc:
        kfio.check(CHECK, **kwargs)  # type: ignore[arg-type]
    assert exc.value.field == field


PLANT = {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]]}
NOISE = {"Q": [[20, 0], [0, 20]], "R": [["5/2"]]}


@pytest.mark.parametrize("name", ["analyze", "bounds"])
def test_a_statespace_gives_the_systems_report(name: str) -> None:
    ss = control.ss(PLANT["A"], [[1], [0]], PLANT["C"], [[0]], 0.1)
    fn = getattr(kfio, name)
    ours = fn(ss, kfio.bernoulli(0.6), **NOISE).to_dict()
    theirs = fn(kfio.System(**PLANT, **NOISE), kfio.bernoulli(0.6)).to_dict()
    assert ours == theirs


def test_a_statespace_gives_the_systems_simulation_and_request() -> None:
    ss = control.ss([[1.2]], [[1]], [[1]], [[0]], True)
    plant = kfio.System(A=[[1.2]], C=[[1]], Q=[[1]], R=[[1]])
    a = kfio.simulate(ss, kfio.bernoulli(0.5), Q=[[1]], R=[[1]], steps=10, trajectories=50, seed=3)
    b = kfio.simulate(plant, kfio.bernoulli(0.5), steps=10, trajectories=50, seed=3)
    assert a.to_dict() == b.to_dict()
    e = kfio.expected_covariance(ss, kfio.bernoulli(0.5), 3, Q=[[1]], R=[[1]])
    assert e.to_dict() == kfio.expected_covariance(plant, kfio.bernoulli(0.5), 3).to_dict()
    assert kfio.request_dict(ss, kfio.bernoulli(0.5), Q=[[1]], R=[[1]]) == kfio.request_dict(plant, kfio.bernoulli(0.5))
    assert kfio.build_request(ss, kfio.bernoulli(0.5), Q=[[1]], R=[[1]]) == kfio.build_request(
        plant, kfio.bernoulli(0.5)
    )


def test_noise_keywords_fill_what_the_system_lacks_and_never_replace() -> None:
    bare = kfio.System(A=[[1.2]], C=[[1]])
    full = kfio.System(A=[[1.2]], C=[[1]], Q=[[1]], R=[[1]])
    assert kfio.request_dict(bare, kfio.bernoulli(0.5), Q=[[1]], R=[[1]]) == kfio.request_dict(
        full, kfio.bernoulli(0.5)
    )
    for key in ("Q", "R"):
        with pytest.raises(kfio.InvalidInput) as exc:
            kfio.analyze(full, kfio.bernoulli(0.5), **{key: [[2]]})
        assert exc.value.field == key
        with pytest.raises(kfio.InvalidInput) as exc:
            kfio.analyze(kfio.build_request(full, kfio.bernoulli(0.5)), **{key: [[2]]})
        assert exc.value.field == key
        with pytest.raises(kfio.InvalidInput) as exc:
            kfio.loop(full, B=[[1]], feedback=[[0.6]], estimator=[[0.5]], channel=kfio.bernoulli(0.8),
                      actuator_channel=kfio.bernoulli(0.9), **{key: [[2]]})  # fmt: skip
        assert exc.value.field == key


def test_a_continuous_statespace_is_refused_naming_system() -> None:
    with pytest.raises(kfio.InvalidInput) as exc:
        kfio.bounds(control.ss([[1]], [[1]], [[1]], [[0]]), kfio.bernoulli(0.5), Q=[[1]], R=[[1]])
    assert exc.value.field == "system" and "c2d" in exc.value.rule


def test_fit_honours_its_budget_and_names_a_bad_one() -> None:
    trace = "0110111011" * 20
    with pytest.raises(kfio.BudgetExceeded):
        kfio.fit(trace, budget=kfio.Budget(max_steps=2))  # one step per candidate: five candidates
    assert kfio.fit(trace, budget=30).to_dict() == kfio.fit(trace).to_dict()
    with pytest.raises(kfio.InvalidInput) as exc:
        kfio.fit(trace, budget=-1)
    assert exc.value.field == "budget"


def test_analyze_budget_raises_on_a_hard_case() -> None:
    hard = kfio.System(A=[[2, 0, 0], [0, -2, 0], [0, 0, 2.0001]], C=[[1, 1, 1]])
    with pytest.raises(kfio.BudgetExceeded):
        kfio.analyze(hard, kfio.bernoulli(0.9), budget=kfio.Budget(max_steps=1))


@pytest.mark.parametrize("flag", ["0", "100000", "-3"])
@pytest.mark.parametrize("command", ["fit", "sweep"])
def test_every_cli_command_checks_time_budget_alike(
    command: str, flag: str, capsys: pytest.CaptureFixture[str]
) -> None:
    target = str(SWEEP) if command == "sweep" else str(ROOT / "examples" / "traces" / next(
        p.name for p in sorted((ROOT / "examples" / "traces").iterdir()) if p.is_file()
    ))  # fmt: skip
    assert main([command, target, "--time-budget", flag]) == 2
    assert "--time-budget: must be in [0.01, 86400] seconds" in capsys.readouterr().err
