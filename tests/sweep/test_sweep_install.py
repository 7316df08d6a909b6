"""One install has everything: the sweep packages are regular dependencies, the documented
example runs, and a missing package is its own error (exit 9, HTTP 503), never "invalid input"."""

from __future__ import annotations

import csv
import json
import sys
import tomllib
from fractions import Fraction
from pathlib import Path

import pytest

from kfio.errors import InvalidInput, MissingDependency
from kfio.service import exitcodes
from kfio.service.cli import build_parser, main
from kfio.service.problems import problem_from_exception

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "sweeps" / "arrival_probability.json"


def test_sweep_packages_are_regular_dependencies():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    names = {d.split(">")[0].split("[")[0].strip() for d in project["dependencies"]}
    assert {"dask", "pyarrow", "tqdm"} <= names
    assert project["optional-dependencies"].get("sweep", []) == []  # kept only as an alias


def test_documented_example_runs_and_turns_stable_past_the_closed_form(tmp_path, capsys):
    out = tmp_path / "table.csv"
    assert main(["sweep", str(EXAMPLE), "--serial", "--quiet", "--out", str(out)]) == exitcodes.STABLE
    rows = list(csv.DictReader(out.open()))
    doc = json.loads(EXAMPLE.read_text())
    assert len(rows) == doc["axes"][0]["num"]
    # one packet, Bernoulli: lambda_c = 1 - 1/max|eig(A)|^2 (Sinopoli et al. 2004, exact for one unstable mode);
    # A is lower triangular, so its eigenvalues are its diagonal
    A = doc["base"]["system"]["A"]
    spectral = max(abs(Fraction(str(A[i][i]))) for i in range(len(A)))
    critical = 1 - 1 / spectral**2
    for row in rows:
        p = Fraction(row["axis:arrival_probability"])  # coordinates are axis:<name> columns
        assert row["verdict"] == ("stable" if p > critical else "unstable" if p < critical else "boundary")
        assert Fraction(row["critical_arrival_probability_exact"]) == critical


def test_missing_dask_is_exit_9_and_names_a_command_that_works(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "distributed", None)  # `import distributed` now raises ImportError
    # the embedded cluster asked for (a small sweep's default engine stays in process, without Dask)
    assert main(["sweep", str(EXAMPLE), "--workers", "2", "--quiet", "--no-progress"]) == 9
    assert exitcodes.MISSING_DEPENDENCY == 9
    err = capsys.readouterr().err
    assert "missing dependency" in err and "kfio sweep --serial" in err
    assert "invalid input" not in err and "kfio[" not in err
    # the command it names works, and so does the default for a sweep this small
    assert main(["sweep", str(EXAMPLE), "--serial", "--quiet"]) == exitcodes.STABLE
    assert main(["sweep", str(EXAMPLE), "--quiet", "--no-progress"]) == exitcodes.STABLE


def test_missing_pyarrow_is_exit_9(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    code = main(["sweep", str(EXAMPLE), "--serial", "--quiet", "--out", str(tmp_path / "t.parquet")])
    err = capsys.readouterr().err
    assert code == exitcodes.MISSING_DEPENDENCY and "pyarrow" in err and ".csv" in err


def test_missing_dependency_is_503_not_an_input_problem():
    exc = MissingDependency("distributed", "the Dask sweep engine", "or run kfio sweep --serial FILE")
    assert not isinstance(exc, InvalidInput) and isinstance(exc, ImportError)
    problem = problem_from_exception(exc)
    assert problem.status == 503 and problem.kind == "missing-dependency" and "distributed" in problem.detail


@pytest.mark.parametrize("text", ["9 a package the feature needs is not installed"])
def test_exit_code_9_is_documented_in_the_help(text):
    assert text in build_parser().epilog
