"""Dump ``kfio analyze --json`` and ``kfio bounds --json`` of every example and page request, to diff.

    python bench/answers_snapshot.py OUTDIR [--kfio PATH]
    diff -r OUTDIR_BEFORE OUTDIR_AFTER

Issue 25 asks that speed work keep every answer identical: run this on the
old and the new code and ``diff -r`` the two directories (empty = identical).
Each file holds the exit code on its first line, then standard output.  No
timing field is printed by these two commands, so nothing is masked.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DIRS = [ROOT / "examples", ROOT / "service" / "static" / "requests"]


def _one(kfio: str, command: str, path: Path, out: Path) -> None:
    proc = subprocess.run([kfio, command, "--json", str(path)], capture_output=True, text=True)
    name = f"{path.parent.name}__{path.stem}.{command}.json"
    (out / name).write_text(f"exit {proc.returncode}\n{proc.stdout}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("outdir", type=Path)
    parser.add_argument("--kfio", default=str(Path(sys.executable).with_name("kfio")))
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    args.outdir.mkdir(parents=True, exist_ok=True)
    files = sorted(p for d in DIRS for p in d.glob("*.json") if p.name != "index.json")
    with ThreadPoolExecutor(args.jobs) as pool:
        for f in [pool.submit(_one, args.kfio, c, p, args.outdir) for p in files for c in ("analyze", "bounds")]:
            f.result()
    print(f"{2 * len(files)} answers in {args.outdir}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
