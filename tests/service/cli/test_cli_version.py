"""``kfio --version`` and ``kfio --help``: one source of the version, no analyzer needed."""

from __future__ import annotations

import os
import subprocess
import sys

import kfio
from kfio.service.cli import main

from support.paths import ROOT

EXAMPLES = ROOT / "examples"


def test_version_and_help_exit_0(capsys):
    assert main(["--version"]) == 0
    assert capsys.readouterr().out == f"kfio {kfio.__version__}\n"
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    assert all(cmd in out for cmd in ("analyze", "bounds", "simulate", "serve", "--version"))


def test_version_as_a_process():
    p = subprocess.run(
        [sys.executable, "-m", "kfio.service.cli", "--version"], capture_output=True, text=True, timeout=60
    )
    assert (p.returncode, p.stdout) == (0, f"kfio {kfio.__version__}\n")


def test_a_closed_pipe_is_not_an_internal_error(tmp_path):
    read, write = os.pipe()
    os.close(read)  # the reader is gone before kfio writes
    try:
        p = subprocess.run(
            [sys.executable, "-m", "kfio.service.cli", "analyze", str(EXAMPLES / "seed004_scalar.json")],
            stdout=write,
            stderr=subprocess.PIPE,
            text=True,
            timeout=120,
        )
    finally:
        os.close(write)
    assert p.returncode == 141 and "internal error" not in p.stderr and "Traceback" not in p.stderr
