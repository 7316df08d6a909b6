"""Helpers of the ``kfio check`` tests: the example layout and a CLI runner."""

from __future__ import annotations

import json
from pathlib import Path

from kfio.service.cli import main

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "check"


def run_cli(capsys, *args: str) -> tuple[int, str, str]:
    """``kfio check args``: the exit code, standard output and standard error."""
    code = main(["check", *args])
    out, err = capsys.readouterr()
    return code, out, err


def edit(path: Path, change) -> None:
    """Apply ``change`` to the JSON tree of the file at ``path``."""
    tree = json.loads(path.read_text())
    change(tree)
    path.write_text(json.dumps(tree))
