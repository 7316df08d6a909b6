"""Benchmark: several sensors on long periods against a previous checkout, same run.

Two sensors (three in the last cases), one Bernoulli channel each (arrival probability 1/2), on
``2 * companion(Phi_m)`` blocks of periods 15, 21, 36 (``Phi_4``, ``Phi_9``)
and 60 (``Phi_3``, ``Phi_4``, ``Phi_5``), with sensor rows ``e_1``, ``e_2``
and with random dense integer rows (entries -3..3, fixed seed).  Each case
runs ``analyze`` end to end in a child process with the current ``kfio`` and
with the checkout given by ``--before`` (the folder holding its
``analyzer/``), under the same limit; CPU seconds of the child are printed
with their ratio, the verdict and the certified blocks.

Run: ``mkdir /tmp/before && git archive <commit> analyzer | tar -x -C /tmp/before`` then
``python bench/bench_sensors.py --before /tmp/before [--limit 60] [--only TEXT]`` (``--only``:
the cases whose name holds ``TEXT``, repeatable).  A case cut off by the limit (wall time) shows the
CPU seconds it had used.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import tempfile

from bench_structure import block_diagonal, cyclotomic_companion, fmt, run


def body(A: list[list[int]], rows: list[list[int]]) -> str:
    system = {"A": A, "C": rows, "sensors": [{"name": f"s{k}", "rows": [k]} for k in range(len(rows))]}
    channel = {
        "model": "per_sensor",
        "channels": {f"s{k}": {"model": "bernoulli", "arrival_probability": "1/2"} for k in range(len(rows))},
    }
    return json.dumps({"system": system, "channel": channel})


def cases() -> list[tuple[str, str]]:
    out = []
    for period, A in [
        (15, block_diagonal(cyclotomic_companion(15))),
        (21, block_diagonal(cyclotomic_companion(21))),
        (36, block_diagonal(cyclotomic_companion(4), cyclotomic_companion(9))),
        (60, block_diagonal(cyclotomic_companion(3), cyclotomic_companion(4), cyclotomic_companion(5))),
    ]:
        n = len(A)
        unit = [[1] + [0] * (n - 1), [0, 1] + [0] * (n - 2)]
        rng = random.Random(period)
        dense = [[rng.randint(-3, 3) for _ in range(n)] for _ in range(2)]
        out.append((f"period {period}, rows e_1, e_2", body(A, unit)))
        out.append((f"period {period}, random dense rows", body(A, dense)))
    # Two dense sensors at period 84, three dense sensors at periods 20, 21 and 36.
    A = block_diagonal(cyclotomic_companion(3), cyclotomic_companion(4), cyclotomic_companion(7))
    rng = random.Random(84)
    out.append(
        ("period 84, random dense rows", body(A, [[rng.randint(-3, 3) for _ in range(len(A))] for _ in range(2)]))
    )
    for period, factors in [(20, (4, 5)), (21, (21,)), (36, (4, 9))]:
        A = block_diagonal(*[cyclotomic_companion(m) for m in factors])
        rng = random.Random(period)
        rows = [[rng.randint(-3, 3) for _ in range(len(A))] for _ in range(3)]
        out.append((f"period {period}, three dense sensors", body(A, rows)))
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", help="checkout of the previous code (holds analyzer/)")
    ap.add_argument("--limit", type=float, default=60.0)
    ap.add_argument("--only", action="append", default=[], help="run the cases whose name holds this text")
    args = ap.parse_args()
    before_path = None
    if args.before:
        before_path = tempfile.mkdtemp(prefix="kfio-before-")
        os.symlink(os.path.join(os.path.abspath(args.before), "analyzer"), os.path.join(before_path, "kfio"))
    print(f"{'case':36s} | {'now':40s} | {'before':40s} | ratio")
    for name, text in cases():
        if args.only and not any(o in name for o in args.only):
            continue
        now = run(text, args.limit, None)
        old = run(text, args.limit, before_path) if before_path else None
        ratio = ""
        if old is not None and "error" not in now:
            cpu = max(now["cpu"], 1e-9)
            if "error" not in old:
                ratio = f"{old['cpu'] / cpu:.1f}x"
            elif old["error"].endswith("BudgetExceeded"):
                ratio = f"> {old['cpu'] / cpu:.1f}x"  # the CPU it used before the cut bounds its total
            else:
                ratio = f"> {args.limit / cpu:.0f}x"
        print(
            f"{name:36s} | {show(now, args.limit):40s} | {show(old, args.limit) if old else '':40s} | {ratio}",
            flush=True,
        )


def show(r: dict, limit: float) -> str:
    """:func:`fmt`, with the CPU seconds used when the limit cut the case off."""
    if str(r.get("error", "")).endswith("BudgetExceeded"):
        return f"cut off at {limit:g} s wall, {r['cpu']:.1f} s CPU"
    return fmt(r, limit)


if __name__ == "__main__":
    main()
