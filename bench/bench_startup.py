"""Benchmark: start-up CPU of the ``kfio`` command and of ``import kfio``.

Each command runs as a whole fresh process; the CPU time (user + system) of
the child is read from ``os.wait4``, so the load of other processes on the
machine hardly matters (wall time would).  Two trees run the same commands in
the same session:

* *before*: the package as it was at ``--baseline`` (default ``736f7c6``, the
  layout commit), extracted with ``git archive`` into a temporary folder;
* *after*: the working tree.

Both are laid out as the wheel installs them (``analyzer/`` as ``kfio``,
``service/`` as ``kfio.service``) in a temporary folder put first on
``PYTHONPATH``, and run with the same interpreter.

Run: ``python bench/bench_startup.py [--baseline REV] [--repeat N]``.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SEED = ROOT / "examples" / "seed004_scalar.json"

CLI = "import sys; from kfio.service.cli import entrypoint; sys.argv[0] = 'kfio'; entrypoint()"
COMMANDS: list[tuple[str, list[str]]] = [
    ("import kfio", ["-c", "import kfio"]),
    ("kfio --help", ["-c", CLI, "--help"]),
    ("kfio --version", ["-c", CLI, "--version"]),
    ("kfio analyze seed004_scalar.json", ["-c", CLI, "analyze", str(SEED)]),
    ("kfio analyze seed004_3x3.json", ["-c", CLI, "analyze", str(ROOT / "examples" / "seed004_3x3.json")]),
]


def layout(src: Path, dest: Path) -> Path:
    """``dest/kfio`` = ``src/analyzer`` with ``src/service`` as ``dest/kfio/service``."""
    pkg = dest / "kfio"
    shutil.copytree(src / "analyzer", pkg, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(src / "service", pkg / "service", ignore=shutil.ignore_patterns("__pycache__"))
    return dest


def checkout(rev: str, dest: Path) -> Path:
    """The tree of ``rev`` (analyzer/ and service/ only), without touching the working tree."""
    dest.mkdir()
    archive = subprocess.run(
        ["git", "-C", str(ROOT), "archive", rev, "analyzer", "service"], check=True, capture_output=True
    ).stdout
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)
    return dest


def cpu_seconds(args: list[str], pythonpath: Path) -> tuple[float, int]:
    """User + system CPU of one child process running ``python args``, and its exit code."""
    env = {**os.environ, "PYTHONPATH": str(pythonpath)}
    with open(os.devnull, "wb") as null:
        proc = subprocess.Popen([sys.executable, *args], env=env, stdout=null, stderr=null, cwd=pythonpath)
        _, status, usage = os.wait4(proc.pid, 0)
    return usage.ru_utime + usage.ru_stime, os.waitstatus_to_exitcode(status)


def check_origin(pythonpath: Path) -> None:
    """The child must import kfio from ``pythonpath``, not from an installed copy."""
    out = subprocess.run(
        [sys.executable, "-c", "import kfio; print(kfio.__file__)"],
        env={**os.environ, "PYTHONPATH": str(pythonpath)},
        capture_output=True,
        text=True,
        check=True,
        cwd=pythonpath,
    ).stdout.strip()
    if not out.startswith(str(pythonpath)):
        raise RuntimeError(f"kfio came from {out}, not {pythonpath}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default="736f7c6", help="git revision of the 'before' column")
    parser.add_argument("--repeat", type=int, default=5, help="runs per command; the median is shown")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        before = layout(checkout(args.baseline, Path(tmp) / "src"), Path(tmp) / "before")
        after = layout(ROOT, Path(tmp) / "after")
        for tree in (before, after):
            check_origin(tree)
            cpu_seconds(["-c", "import kfio.service.cli"], tree)  # write the .pyc files first
        print(f"CPU seconds per process (median of {args.repeat}; user + system)")
        print(f"{'command':36} {'before ' + args.baseline:>16} {'after':>8} {'ratio':>7}")
        for name, cmd in COMMANDS:
            cells = []
            for tree in (before, after):
                runs = [cpu_seconds(cmd, tree) for _ in range(args.repeat)]
                codes = {code for _, code in runs}
                t = statistics.median(cpu for cpu, _ in runs)
                cells.append((t, "" if codes <= {0, 1, 3} else f" (exit {max(codes)})"))
            (b, bnote), (a, anote) = cells
            print(f"{name:36} {f'{b:.3f}{bnote}':>16} {f'{a:.3f}{anote}':>8} {b / a:6.1f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
