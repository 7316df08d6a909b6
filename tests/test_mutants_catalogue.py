"""The mutants of bench/mutation.py stay applicable: each old text occurs once, each test file exists."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _mutation():
    spec = importlib.util.spec_from_file_location("kfio_bench_mutation", ROOT / "bench" / "mutation.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


MUTATION = _mutation()


def test_the_issue_21_mutants_are_listed() -> None:
    names = {m.name for m in MUTATION.MUTANTS}
    assert {
        "unit-modulus-skipped",
        "lambda-upper-midpoint",
        "ge-boundary-float-recurrence",
        "band-halved",
        "float-binary-value",
        "exponent-limit-inclusive",
        "exponent-limit-past-edge",
    } <= names
    assert len(names) == len(MUTATION.MUTANTS)


@pytest.mark.parametrize("mutant", [m for m in MUTATION.MUTANTS if m.path], ids=lambda m: m.name)
def test_each_mutant_applies_once_and_changes_the_code(mutant) -> None:
    text = (ROOT / mutant.path).read_text(encoding="utf-8")
    assert text.count(mutant.old) == 1
    assert mutant.new != mutant.old
    assert mutant.tests and all((ROOT / t).is_file() for t in mutant.tests)


def test_a_stale_mutant_is_reported_and_nothing_is_written(tmp_path, monkeypatch) -> None:
    target = tmp_path / "m.py"
    target.write_text("x = 1\n", encoding="utf-8")
    monkeypatch.setattr(MUTATION, "ROOT", tmp_path)
    stale = MUTATION.Mutant("stale", "m.py", "y = 2\n", "y = 3\n", ("t.py",), "not there")
    assert MUTATION.run(stale) == "stale"
    assert target.read_text(encoding="utf-8") == "x = 1\n"
