"""Benchmark: certified exact structure against the previous code, in the same run.

Each case runs ``analyze`` end to end in a child process, once with the
current ``kfio`` and once with a previous checkout (``--before``: the folder
holding that checkout's ``analyzer/`` package, imported as ``kfio`` through a
symlink), with the same time limit; CPU seconds of the ``analyze`` call in the child
are reported (after a warm-up analysis, so that no side times its lazy
imports), with the ratio, the verdict and how many blocks are
``certified: true``.

Cases: dense random integer matrices (entries -3..3, ``C = e_1``, Bernoulli
1/2) of size 16, 24, 40; the seed systems and structured cases of
``bench_verdict.py`` (period 60, 12 x 12 repeated Jordan blocks); two sensors
on periods 15, 21, 36, 60 (``2 * companion(Phi_m)`` blocks, rows ``e_1`` and
``e_2``); one sensor at periods 120, 168, 210 (companion of ``1.1 zeta_N``).

Run: ``git worktree add /tmp/kfio-before 736f7c6`` then
``python bench/bench_structure.py --before /tmp/kfio-before [--limit 120] [--only TEXT]``.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import subprocess
import sys
import tempfile
from fractions import Fraction

from bench_verdict import cases as verdict_cases
from flint import fmpz_poly

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests"))

from support.plants import block_diagonal, cyclotomic_companion  # noqa: E402

CHILD = r"""
import json, sys, time
from kfio import analyze, load_request
from kfio._budget import Budget
from kfio.model._limits import DEFAULT_LIMITS
LIMITS = DEFAULT_LIMITS.for_command("analyze")  # the states kfio analyze accepts (48 at period 210)
body = sys.stdin.read()
# Warm up first: kfio imports SymPy, SciPy and python-flint on first use, which would
# otherwise land in the timed call of one side and not the other (an eager import
# before the start-up work). A scalar plant, and two sensors on a period-3 block.
for warm in (
    '{"system": {"A": [[2]], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": "1/2"}}',
    '{"system": {"A": [[0, -2], [2, -2]], "C": [[1, 0], [0, 1]], "sensors": [{"name": "a", "rows": [0]}, '
    '{"name": "b", "rows": [1]}]}, "channel": {"model": "per_sensor", "channels": {"a": {"model": "bernoulli", '
    '"arrival_probability": "1/2"}, "b": {"model": "bernoulli", "arrival_probability": "1/2"}}}}',
):
    analyze(load_request(warm))
t = time.process_time()
try:
    rep = analyze(load_request(body, LIMITS), budget=Budget(seconds=float(sys.argv[1])))
    out = {"cpu": time.process_time() - t, "verdict": rep.verdict,
           "certified": sum(b.certified for b in rep.blocks), "blocks": len(rep.blocks)}
except Exception as exc:
    out = {"cpu": time.process_time() - t, "error": type(exc).__name__}
print(json.dumps(out))
"""


def dense(n: int) -> tuple[str, list, list, dict]:
    rng = random.Random(n)
    A = [[rng.randint(-3, 3) for _ in range(n)] for _ in range(n)]
    return f"dense random {n}x{n}", A, [[1] + [0] * (n - 1)], {"model": "bernoulli", "arrival_probability": "1/2"}


def two_sensor_bodies() -> list[tuple[str, str]]:
    out = []
    for name, A in [
        ("two sensors, period 15", block_diagonal(cyclotomic_companion(15))),
        ("two sensors, period 21", block_diagonal(cyclotomic_companion(21))),
        ("two sensors, period 36", block_diagonal(cyclotomic_companion(4), cyclotomic_companion(9))),
        (
            "two sensors, period 60",
            block_diagonal(cyclotomic_companion(3), cyclotomic_companion(4), cyclotomic_companion(5)),
        ),
    ]:
        n = len(A)
        system = {
            "A": A,
            "C": [[1] + [0] * (n - 1), [0, 1] + [0] * (n - 2)],
            "sensors": [{"name": "s1", "rows": [0]}, {"name": "s2", "rows": [1]}],
        }
        channel = {
            "model": "per_sensor",
            "channels": {s: {"model": "bernoulli", "arrival_probability": "1/2"} for s in ("s1", "s2")},
        }
        out.append((name, json.dumps({"system": system, "channel": channel})))
    return out


def zeta_companion(N: int) -> tuple[str, list, list, dict]:
    """Companion of the minimal polynomial of ``1.1 zeta_N`` (``C = e_1``, Bernoulli 1/2): one sensor at period ``N``.

    The monic polynomial ``(11/10)^d Phi_N(10 x / 11)``, ``d = phi(N)``: its roots
    ``1.1 zeta_N^k`` form one FMO block over ``Q(zeta_N)``.
    """
    c = [int(x) for x in fmpz_poly.cyclotomic(N).coeffs()]
    d = len(c) - 1
    m = [Fraction(c[i]) * Fraction(11, 10) ** (d - i) for i in range(d + 1)]
    A = [["0"] * d for _ in range(d)]
    for i in range(1, d):
        A[i][i - 1] = "1"
    for i in range(d):
        A[i][d - 1] = str(-m[i])
    return f"companion of 1.1 zeta_{N} ({d} states)", A, [["1"] + ["0"] * (d - 1)], BERNOULLI


BERNOULLI = {"model": "bernoulli", "arrival_probability": "1/2"}


def bodies() -> list[tuple[str, str]]:
    out = []
    cases = [dense(16), dense(24), dense(40)] + verdict_cases() + [zeta_companion(N) for N in (120, 168, 210)]
    for name, A, C, ch in cases:
        out.append((name, json.dumps({"system": {"A": A, "C": C}, "channel": ch})))
    return out + two_sensor_bodies()


def run(body: str, limit: float, pythonpath: str | None) -> dict:
    env = dict(os.environ)
    if pythonpath is not None:
        env["PYTHONPATH"] = pythonpath
    try:
        res = subprocess.run(
            [sys.executable, "-c", CHILD, str(limit)],
            input=body,
            capture_output=True,
            text=True,
            timeout=limit + 30,
            env=env,
        )
        return json.loads(res.stdout.strip().splitlines()[-1])
    except (subprocess.TimeoutExpired, IndexError, json.JSONDecodeError):
        return {"cpu": float("inf"), "error": "timeout"}


def fmt(r: dict, limit: float) -> str:
    if "error" in r:
        return f"> {limit:g} s ({r['error']})" if r["error"] in ("timeout", "BudgetExceeded") else r["error"]
    return f"{r['cpu']:.3f} s, {r['verdict']}, {r['certified']}/{r['blocks']} certified"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", help="checkout of the previous code (holds analyzer/)")
    ap.add_argument("--limit", type=float, default=120.0)
    ap.add_argument("--only", help="run only the cases whose name contains this text")
    args = ap.parse_args()
    before_path = None
    if args.before:
        before_path = tempfile.mkdtemp(prefix="kfio-before-")
        os.symlink(os.path.join(os.path.abspath(args.before), "analyzer"), os.path.join(before_path, "kfio"))
    print(f"{'case':42s} | {'now':40s} | {'before':40s} | ratio")
    for name, body in bodies():
        if args.only and args.only not in name:
            continue
        now = run(body, args.limit, None)
        old = run(body, args.limit, before_path) if before_path else None
        ratio = ""
        if old is not None and "error" not in now:
            ratio = (
                f"{old['cpu'] / max(now['cpu'], 1e-9):.1f}x"
                if "error" not in old
                else f"> {args.limit / max(now['cpu'], 1e-9):.0f}x"
            )
        print(
            f"{name:42s} | {fmt(now, args.limit):40s} | {fmt(old, args.limit) if old else '-':40s} | {ratio}",
            flush=True,
        )


if __name__ == "__main__":
    main()
