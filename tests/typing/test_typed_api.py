"""Typed downstream code: ``mypy --strict`` on tests/typing/downstream.py finds kfio's hints through ``py.typed``.

kfio is installed into a fresh virtual environment the way PEP 561 sees a
package: a folder named ``kfio`` (this checkout's ``analyzer/``) on a path
line of its site-packages, which mypy reads only because of ``py.typed``.
A second file with two type errors shows the hints are real types, not
``Any``: mypy must reject exactly those lines.
"""

from __future__ import annotations

import os
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
"""


def test_py_typed_ships_in_the_package() -> None:
    text = (REPO / "pyproject.toml").read_text()
    assert (REPO / "analyzer" / "py.typed").exists() and '"kfio" = ["py.typed"]' in text


def test_mypy_strict_passes_on_downstream_code_and_rejects_wrong_code(tmp_path: Path) -> None:
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

    wrong = tmp_path / "wrong.py"
    wrong.write_text(WRONG)
    env = {k: v for k, v in os.environ.items() if k not in ("MYPYPATH", "PYTHONPATH")}
    out = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--python-executable", str(py), "--cache-dir",
         str(tmp_path / "cache"), "--no-error-summary", str(DOWNSTREAM), str(wrong)],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    errors = [line for line in out.stdout.splitlines() if ": error:" in line]
    assert not [e for e in errors if "downstream.py" in e], out.stdout
    assert [e.split(":")[1] for e in errors] == ["4", "5"], out.stdout + out.stderr
    assert 'expression has type "Verdict", variable has type "int"' in errors[0]
    assert 'incompatible type "list[float]"' in errors[1]
