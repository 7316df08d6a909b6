"""Compare two ``bench/answers_snapshot.py`` directories: exact fields identical, float fields within a bound.

    python bench/compare_answers.py BEFORE_DIR AFTER_DIR [--tolerance 1e-7]

The rule for speed work: every exact field and verdict identical; floats that come out of a
numerical solver may move in their last bits.  Each answer file's JSON is walked in both
directories.  Strings, integers, booleans, nulls and the structure must be equal.  A list of
numbers (a matrix row or a whole matrix) is compared as one array, relative to its largest
entry; a lone number relative to itself.  Prints every differing path with its relative change,
the largest one, and exits 1 if an exact field differs or a change exceeds the tolerance.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path


def _load(path: Path):
    text = path.read_text()
    body = text.split("\n", 1)[1].split("\n--- stderr\n", 1)[0]
    try:
        return json.loads(body)
    except json.JSONDecodeError:
        return body  # not JSON (an error message): compared as text


def _flat(x) -> list | None:
    """The numbers of ``x`` (a number or nested lists of numbers) in order, else ``None``."""
    if isinstance(x, bool) or x is None:
        return None
    if isinstance(x, (int, float)):
        return [x]
    if isinstance(x, list) and x:
        out: list = []
        for y in x:
            got = _flat(y)
            if got is None:
                return None
            out += got
        return out
    return None


def _numbers(x) -> list[float] | None:
    """Float fields: a float, or a list of numbers holding a float (integers alone are exact)."""
    got = _flat(x)
    if got is None or not any(isinstance(v, float) for v in got):
        return None
    return [float(v) for v in got]


def compare(a, b, path: str, floats: dict[str, float], exact: list[str]) -> None:
    na, nb = _numbers(a), _numbers(b)
    if na is not None and nb is not None and len(na) == len(nb):
        scale = max(abs(v) for v in nb) or 1.0
        d = max(abs(x - y) for x, y in zip(na, nb)) / scale
        if d > 0:
            floats[path] = d
        return
    if isinstance(a, dict) and isinstance(b, dict):
        if a.keys() != b.keys():
            exact.append(f"{path}: keys {sorted(a.keys() ^ b.keys())}")
        for k in a.keys() & b.keys():
            compare(a[k], b[k], f"{path}/{k}", floats, exact)
        return
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b)):
            compare(x, y, f"{path}/{i}", floats, exact)
        return
    if a != b or type(a) is not type(b):
        exact.append(f"{path}: {str(a)[:80]!r} != {str(b)[:80]!r}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("before", type=Path)
    ap.add_argument("after", type=Path)
    ap.add_argument("--tolerance", type=float, default=1e-7)
    args = ap.parse_args()
    floats: dict[str, float] = {}
    exact: list[str] = []
    names = sorted(p.name for p in args.before.glob("*.json"))
    for name in names:
        other = args.after / name
        if not other.exists():
            exact.append(f"{name}: missing")
            continue
        compare(_load(other), _load(args.before / name), name, floats, exact)
    for line in exact:
        print("EXACT", line)
    for k, v in sorted(floats.items(), key=lambda kv: -kv[1]):
        print(f"FLOAT {v:.2e} {k}")
    worst = max(floats.values(), default=0.0)
    print(
        f"{len(names)} answers; exact fields differing: {len(exact)}; float paths differing: {len(floats)}, largest relative change {worst:.2e}"
    )
    return 1 if exact or worst > args.tolerance else 0


if __name__ == "__main__":
    raise SystemExit(main())
