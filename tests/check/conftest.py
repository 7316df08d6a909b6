"""The example layout of ``kfio check`` (examples/check/), run once per session through the CLI."""

from __future__ import annotations

import io
import json
import shutil
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

from kfio.service.cli import main

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "check"


def run_cli(capsys, *args: str) -> tuple[int, str, str]:
    code = main(["check", *args])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="session")
def example_runs(tmp_path_factory):
    """``kfio check`` on the passing and the failing example, with every output format written."""
    tmp = tmp_path_factory.mktemp("check")
    runs = {}
    for name, flags in (("kfio-check.json", []), ("kfio-check-failing.json", ["--json"])):
        stem = name.removesuffix(".json")
        junit, md = tmp / f"{stem}.xml", tmp / f"{stem}.md"
        out, err = io.StringIO(), io.StringIO()
        with redirect_stdout(out), redirect_stderr(err):
            code = main(["check", str(EXAMPLE / name), "--junit", str(junit), "--markdown", str(md), *flags])
        runs[name] = {
            "code": code,
            "out": out.getvalue(),
            "err": err.getvalue(),
            "junit": junit.read_text(),
            "markdown": md.read_text(),
        }
    return runs


@pytest.fixture()
def layout(tmp_path):
    """A copy of examples/check/ to edit."""
    dest = tmp_path / "layout"
    shutil.copytree(EXAMPLE, dest)
    return dest


def edit(path: Path, change) -> None:
    tree = json.loads(path.read_text())
    change(tree)
    path.write_text(json.dumps(tree))
