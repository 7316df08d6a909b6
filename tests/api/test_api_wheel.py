"""A non-editable install: build the wheel, install it into a fresh venv, use it there.

The wheel must hold one top-level package, ``kfio`` (with ``kfio.service``),
and nothing named ``analyzer``, ``service`` or ``tests``.  The fresh venv gets
the wheel without dependencies; the dependencies come from this interpreter's
site-packages through a ``.pth`` line (which does not run that folder's own
``.pth`` files, so this checkout's editable install stays out of it).  Only
pip's build requirements come from the package index, as in the Dockerfile test.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

import kfio

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[2]


def run(args: list[str], cwd: Path, **kw) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PIP_REQUIRE_VIRTUALENV")}
    return subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=600, **kw)


def test_wheel_installs_kfio_and_nothing_generic(tmp_path: Path) -> None:
    src = tmp_path / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy2(REPO / name, src / name)
    for name in ("analyzer", "service"):
        shutil.copytree(REPO / name, src / name, ignore=shutil.ignore_patterns("__pycache__"))
    built = run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path / "dist"), str(src)], tmp_path
    )
    assert built.returncode == 0, built.stderr[-3000:]
    (wheel,) = (tmp_path / "dist").glob("kfio-*.whl")
    assert wheel.name.startswith(f"kfio-{kfio.__version__}-")
    with zipfile.ZipFile(wheel) as zf:
        top = {n.split("/")[0] for n in zf.namelist()}
        typed = "kfio/py.typed" in zf.namelist()  # PEP 561: type checkers read the annotations
        metadata = zf.read(f"kfio-{kfio.__version__}.dist-info/METADATA").decode()
    assert top == {"kfio", f"kfio-{kfio.__version__}.dist-info"} and typed
    assert f"Version: {kfio.__version__}" in metadata and "Provides-Extra: control" in metadata

    venv = tmp_path / "venv"
    assert run([sys.executable, "-m", "venv", "--without-pip", str(venv)], tmp_path).returncode == 0
    py = venv / "bin" / "python"
    site = Path(
        run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], tmp_path).stdout.strip()
    )
    installed = run(
        [sys.executable, "-m", "pip", "--python", str(py), "install", "--no-deps", "--no-index", "-q", str(wheel)],
        tmp_path,
    )
    assert installed.returncode == 0, installed.stderr[-3000:]
    (site / "kfio_test_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    assert not {"analyzer", "service", "tests"} & {p.name for p in site.iterdir()}

    probe = run(
        [str(py), "-c", "import json, kfio, kfio.service.app; print(json.dumps([kfio.__file__, kfio.__version__]))"],
        tmp_path,
    )
    assert probe.returncode == 0, probe.stderr
    where, version = json.loads(probe.stdout)
    assert where.startswith(str(site)) and version == kfio.__version__

    kfio_cmd = str(venv / "bin" / "kfio")
    assert run([kfio_cmd, "--version"], tmp_path).stdout == f"kfio {kfio.__version__}\n"
    analyzed = run([kfio_cmd, "analyze", str(REPO / "examples" / "seed004_scalar.json"), "--json"], tmp_path)
    assert analyzed.returncode == 0 and json.loads(analyzed.stdout)["kfio_version"] == kfio.__version__
    assert run([kfio_cmd, "serve", "--help"], tmp_path).returncode == 0
    spec = run([str(py), "-m", "kfio.service.openapi_gen", "--output", str(tmp_path / "openapi.json")], tmp_path)
    assert spec.returncode == 0, spec.stderr
    assert json.loads((tmp_path / "openapi.json").read_text())["info"]["version"] == kfio.__version__
