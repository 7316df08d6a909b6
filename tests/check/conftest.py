"""Fixtures of the ``kfio check`` tests: the example layout (examples/check/), run once per session."""

from __future__ import annotations

import io
import shutil
from contextlib import redirect_stderr, redirect_stdout

import pytest

from kfio.service.cli import main

from support.check_layout import EXAMPLE


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
