"""Dump ``kfio analyze --json`` and ``kfio bounds --json`` of every example and page request, to diff.

    python bench/answers_snapshot.py OUTDIR [--reference COMMIT] [--commands analyze,bounds,simulate]
    diff -r OUTDIR_BEFORE OUTDIR_AFTER

Speed work must keep every answer identical: run this on this
checkout and with ``--reference COMMIT`` (that commit's library, unpacked by
:mod:`_reference`) and ``diff -r`` the two directories (empty = identical).
Each file holds the exit code on its first line, then standard output, then
standard error.  No timing field is printed by these two commands, so nothing
is masked.  ``--commands`` adds others (``simulate``: the default seeded
Monte Carlo of each file, whose JSON must stay identical too).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DIRS = [ROOT / "examples", ROOT / "service" / "static" / "requests"]


CLI = "import sys; from kfio.service.cli import main; sys.exit(main())"


def _one(env: dict[str, str], command: str, path: Path, out: Path) -> None:
    proc = subprocess.run(
        [sys.executable, "-c", CLI, command, "--json", str(path)], capture_output=True, text=True, env=env
    )
    name = f"{path.parent.name}__{path.stem}.{command}.json"
    (out / name).write_text(f"exit {proc.returncode}\n{proc.stdout}\n--- stderr\n{proc.stderr}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("outdir", type=Path)
    parser.add_argument("--reference", help="commit whose library answers instead of this checkout's")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--commands", default="analyze,bounds", help="comma-separated CLI commands to run")
    args = parser.parse_args()
    args.outdir.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ)
    if args.reference:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from _reference import reference_tree

        env["PYTHONPATH"] = str(reference_tree(args.reference))
    commands = args.commands.split(",")
    files = sorted(p for d in DIRS for p in d.glob("*.json") if p.name != "index.json")
    with ThreadPoolExecutor(args.jobs) as pool:
        for f in [pool.submit(_one, env, c, p, args.outdir) for p in files for c in commands]:
            f.result()
    print(f"{len(commands) * len(files)} answers in {args.outdir}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
