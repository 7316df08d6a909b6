"""Type-check kfio as the package it installs as: ``python scripts/typecheck.py [mypy options]``.

The sources live in ``analyzer/`` (the package ``kfio``) and ``service/``
(``kfio.service``); setuptools' editable install maps those folders to the
import names with an import hook, which mypy cannot follow.  Run on the
folders (``mypy analyzer service``), mypy names the library's modules
``analyzer.*`` and finds no ``kfio`` at all, so every ``from kfio import ...``
of the service would be ``Any`` and its calls into the library unchecked.

This script lays the installed package out as links, ``kfio/`` holding every
entry of ``analyzer/`` and ``kfio/service`` pointing at ``service/``, under
``.mypy_cache/`` (rebuilt on every run, so a new module is seen at once),
and runs ``mypy -p kfio`` on it, ``strict`` as ``pyproject.toml`` says.
Exit status: mypy's.  CI and the pre-commit hook run exactly this.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LINKS = ROOT / ".mypy_cache" / "kfio-links"


def link_tree(root: Path = ROOT, links: Path = LINKS) -> Path:
    """``links/kfio``: links to each entry of ``root/analyzer`` and ``service`` -> ``root/service``."""
    package = links / "kfio"
    if links.exists():
        shutil.rmtree(links)
    package.mkdir(parents=True)
    for entry in sorted((root / "analyzer").iterdir()):
        if entry.name != "__pycache__":
            (package / entry.name).symlink_to(entry)
    (package / "service").symlink_to(root / "service")
    return links


def source_path(line: str, links: Path = LINKS) -> str:
    """A line of mypy's output with a linked path written as the source file's path in the checkout.

    >>> source_path(".mypy_cache/kfio-links/kfio/service/plots.py:3: error: x")
    'service/plots.py:3: error: x'
    >>> source_path(".mypy_cache/kfio-links/kfio/_api.py:3: error: x")
    'analyzer/_api.py:3: error: x'
    """
    prefix = str(links.relative_to(ROOT) / "kfio") + "/"
    if not line.startswith(prefix):
        return line
    rest = line[len(prefix) :]
    return rest if rest.startswith("service/") else "analyzer/" + rest


def main(argv: list[str]) -> int:
    links = link_tree()
    env = dict(os.environ, MYPYPATH=str(links))
    cmd = [sys.executable, "-m", "mypy", *argv, "-p", "kfio"]
    done = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    sys.stdout.write("".join(source_path(line) + "\n" for line in done.stdout.splitlines()))
    sys.stderr.write(done.stderr)
    return done.returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
