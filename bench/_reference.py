"""Run the previous code (a commit of this repository) in a subprocess, for same-run ratios in the benchmarks.

``git archive COMMIT analyzer service`` is unpacked once into a temporary folder as the package ``kfio``
(with ``service/`` as ``kfio.service``, the installed layout) and put first on ``PYTHONPATH`` of a child
interpreter, which runs a snippet and prints one JSON line.
"""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path
from typing import Any

#: The reference library of the speed benchmarks: the package layout before the kernel and service speed work.
REFERENCE_COMMIT = "736f7c6"
ROOT = Path(__file__).resolve().parents[1]


def unpack(commit: str, dest: Path) -> None:
    """``git archive COMMIT analyzer service`` unpacked into ``dest`` as they were in the repository."""
    blob = subprocess.run(
        ["git", "archive", commit, "analyzer", "service"], cwd=ROOT, check=True, capture_output=True
    ).stdout
    with tarfile.open(fileobj=io.BytesIO(blob)) as tar:
        tar.extractall(dest, filter="data")


def reference_tree(commit: str = REFERENCE_COMMIT) -> Path:
    """A folder holding ``kfio/`` (the library, and ``kfio/service``) as of ``commit``."""
    dest = Path(tempfile.gettempdir()) / f"kfio-reference-{commit}-service"
    if not (dest / "kfio" / "service" / "__init__.py").exists():
        unpack(commit, dest / "_x")
        (dest / "_x" / "analyzer").rename(dest / "kfio")
        (dest / "_x" / "service").rename(dest / "kfio" / "service")
    return dest


def run_reference(code: str, commit: str = REFERENCE_COMMIT, timeout: float = 3600) -> Any:
    """Run ``code`` against the library of ``commit``; it must print a JSON document on its last line."""
    env = dict(os.environ, PYTHONPATH=str(reference_tree(commit)))
    out = subprocess.run(
        [sys.executable, "-c", "import kfio, sys; assert 'kfio-reference' in kfio.__file__, kfio.__file__\n" + code],
        env=env,
        check=True,
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])
