"""Typed downstream code: ``mypy --strict`` on tests/typing/downstream.py finds kfio's hints through ``py.typed``.

kfio is installed into a fresh virtual environment the way PEP 561 sees a
package: a folder named ``kfio`` (this checkout's ``analyzer/``) on a path
line of its site-packages, which mypy reads only because of ``py.typed``.
A second file with type errors shows the hints are real types, not
``Any``: mypy must reject exactly those lines.  ``kfio.loop`` is checked to
be the typed function (its keywords, its report), not the subpackage of the
same name.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[2]
DOWNSTREAM = Path(__file__).with_name("downstream.py")

WRONG = """\
import kfio

report = kfio.analyze(kfio.System(A=[[2]], C=[[1]]), kfio.bernoulli("1/2"))
count: int = report.verdict
channel = kfio.bernoulli([0.5])
plant = kfio.System(A=[[2]], C=[[1]], Q=[[1]], R=[[1]])
kfio.loop(plant, B=[[1]], K=[[1]], L=[[1]], channel=kfio.bernoulli(0.9), actuator_channel=kfio.bernoulli(0.9))
text: str = kfio.loop(plant, B=[[1]], feedback=[[1]], estimator=[[1]], channel=kfio.bernoulli(0.9), actuator_channel=kfio.bernoulli(0.9))
"""


def test_py_typed_ships_in_the_package() -> None:
    text = (REPO / "pyproject.toml").read_text()
    assert (REPO / "analyzer" / "py.typed").exists() and '"kfio" = ["py.typed"]' in text


@pytest.fixture(scope="module")
def downstream_python(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A fresh virtual environment that sees this checkout's kfio the way PEP 561 sees a package."""
    tmp_path = tmp_path_factory.mktemp("typing")
    src = tmp_path / "src"
    src.mkdir()
    (src / "kfio").symlink_to(REPO / "analyzer", target_is_directory=True)
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    py = venv / "bin" / "python"
    site = subprocess.run(
        [str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    # .pth files are read in name order: this checkout's kfio before any kfio among the dependencies
    (Path(site) / "00_kfio_checkout.pth").write_text(f"{src}\n")
    deps = [p for p in sys.path if p.endswith("-packages") and Path(p).is_dir()]  # numpy's stubs among them
    (Path(site) / "zz_dependencies.pth").write_text("".join(f"{p}\n" for p in deps))
    where = subprocess.run([str(py), "-c", "import kfio; print(kfio.__file__)"], capture_output=True, text=True)
    assert where.stdout.startswith(str(src)), where.stderr
    return py


def _mypy(py: Path, tmp_path: Path, *files: Path) -> str:
    env = {k: v for k, v in os.environ.items() if k not in ("MYPYPATH", "PYTHONPATH")}
    out = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--python-executable", str(py), "--cache-dir",
         str(py.parents[2] / "cache"), "--no-error-summary", *map(str, files)],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    return out.stdout + out.stderr


def test_mypy_strict_passes_on_downstream_code_and_rejects_wrong_code(downstream_python: Path, tmp_path: Path) -> None:
    wrong = tmp_path / "wrong.py"
    wrong.write_text(WRONG)
    out = _mypy(downstream_python, tmp_path, DOWNSTREAM, wrong)
    errors = [line for line in out.splitlines() if ": error:" in line]
    assert not [e for e in errors if "downstream.py" in e], out
    assert [e.split(":")[1] for e in errors] == ["4", "5", "7", "7", "8"], out
    assert 'expression has type "Verdict", variable has type "int"' in errors[0]
    assert 'incompatible type "list[float]"' in errors[1]
    assert 'Unexpected keyword argument "K"' in errors[2]  # the letters are no keywords of kfio.loop
    assert 'Unexpected keyword argument "L"' in errors[3]
    assert 'expression has type "LoopReport", variable has type "str"' in errors[4]


def test_kfio_loop_is_a_typed_function_with_keywords_not_a_module(downstream_python: Path, tmp_path: Path) -> None:
    probe = tmp_path / "probe.py"
    probe.write_text("import kfio\nreveal_type(kfio.loop)\n")
    out = _mypy(downstream_python, tmp_path, probe)
    (note,) = [line for line in out.splitlines() if "Revealed type is" in line]
    assert '"def (system: ' in note and note.endswith('-> kfio.loop._report.LoopReport"'), note
    keywords = re.findall(r"(?:\*, |, )(\w+): ", note)
    assert keywords[:6] == ["feedback", "estimator", "form", "lqg", "channel", "actuator_channel"], note
    assert keywords[-3:] == ["cost", "options", "budget"], note
    assert "feedback: typing.Sequence[typing.Sequence[" in note and "form: Literal['predictor']" in note


PUBLIC = {
    "analyze": "kfio.stability._verdict.StabilityReport",
    "bounds": "kfio.riccati_bounds",
    "simulate": "kfio.simulation",
    "expected_covariance": "kfio.simulation",
    "loop": "kfio.loop._report.LoopReport",
    "fit": "kfio.fit._fit.FitReport",
    "sweep": "kfio.sweep._engine.SweepResult",
    "check": "kfio.check._run.CheckResult",
}


def test_every_public_function_is_a_typed_callable_with_its_parameters(downstream_python: Path, tmp_path: Path) -> None:
    probe = tmp_path / "probe_all.py"
    probe.write_text("import kfio\n" + "".join(f"reveal_type(kfio.{name})\n" for name in PUBLIC))
    out = _mypy(downstream_python, tmp_path, probe)
    notes = [line for line in out.splitlines() if "Revealed type is" in line]
    assert len(notes) == len(PUBLIC), out
    for (name, result), note in zip(PUBLIC.items(), notes):
        assert '"def (' in note and "*args: Any" not in note and "**kwargs: Any" not in note, (name, note)
        assert "budget: kfio._budget.Budget | typing.SupportsFloat" in note, (name, note)
        assert f"-> {result}" in note, (name, note)
        assert "module" not in note.lower(), (name, note)
    sweep_note = notes[list(PUBLIC).index("sweep")]
    assert all(f"{k}: " in sweep_note for k in ("spec", "engine", "scheduler", "workers", "chunk_size", "progress")), (
        sweep_note
    )
    check_note = notes[list(PUBLIC).index("check")]
    assert all(f"{k}: " in check_note for k in ("spec", "base", "allow_outside", "workers", "memory_bytes")), check_note
    analyze_note = notes[0]
    assert "system: kfio._system.System | kfio._typing.StateSpaceLike | kfio.model._types.Request" in analyze_note
