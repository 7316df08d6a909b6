"""A small mutation check: plant one known bug at a time and see whether the tests notice.

Each mutant names a file, an exact piece of its text, the text that replaces it,
and the tests that should fail.  For each mutant this script

1. checks that the old text occurs exactly once in the file (else the mutant is
   stale: the code moved, and the entry must be updated),
2. writes the mutated file in place,
3. runs the mutant's tests in a fresh ``python -m pytest -x -q`` (no bytecode is
   written, so no cached mutant survives the run),
4. restores the original bytes and modification time in a ``finally`` block,
   whatever happened (a test crash, Ctrl-C),

and prints ``killed`` (some test failed) or ``SURVIVED`` (every test passed).  The
exit status is 0 when every mutant was killed, 1 otherwise, 2 for a stale mutant.

Run it from a clean checkout (it edits the files in place, one at a time):

    python bench/mutation.py              # every mutant
    python bench/mutation.py --list       # names only
    python bench/mutation.py unit-modulus-skipped band-halved

To check a module of your own, add entries to :data:`MUTANTS`: one bug a test
should catch, the smallest relevant test files, and what the bug means.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Mutant:
    """One planted bug: replace ``old`` (exactly once in ``path``) by ``new``, then run ``tests``."""

    name: str
    path: str
    old: str
    new: str
    tests: tuple[str, ...]
    why: str


MUTANTS: tuple[Mutant, ...] = (
    Mutant(
        "unit-modulus-skipped",
        "analyzer/stability/_verdict.py",
        "    if below_one < 0:\n",
        "    if below_one <= 0:\n",
        ("tests/stability/test_unit_modulus.py", "tests/stability/test_verdict.py"),
        "blocks with |alpha| = 1 skipped as stable: A = [[1]], C = [[0]] must be boundary",
    ),
    Mutant(
        "lambda-upper-midpoint",
        "analyzer/riccati_bounds/_search.py",
        "            hi, cert, probed = probe, c, True\n        return UpperBound(hi, cert, lo, self.solves - steps0)\n",
        "            hi, cert, probed = probe, c, True\n        return UpperBound((lo + hi) / 2, cert, lo, self.solves - steps0)\n",
        ("tests/riccati_bounds/test_lambda_upper_certified.py",),
        "lambda_upper reports the bracket's midpoint, not the certified point (solver-free route)",
    ),
    Mutant(
        "lambda-upper-midpoint-bisection",
        "analyzer/riccati_bounds/_search.py",
        "                lo = mid\n        return UpperBound(hi, cert, lo, self.solves - steps0)\n",
        "                lo = mid\n        return UpperBound((lo + hi) / 2, cert, lo, self.solves - steps0)\n",
        ("tests/riccati_bounds/test_lambda_upper_certified.py",),
        "lambda_upper reports the bracket's midpoint, not the certified point (LMI bisection)",
    ),
    Mutant(
        "ge-boundary-float-recurrence",
        "analyzer/design/_ge_region.py",
        "        out: np.ndarray = _rho(self.gaps, p, q, np.ones(np.broadcast(p, q).shape))\n",
        "        out: np.ndarray = _rho(self.gaps, p, q, np.ones(np.broadcast(p, q).shape)) * (1 + 1e-4)\n",
        ("tests/service/test_plot_ge_boundary.py",),
        "the float evaluation of the Gilbert-Elliott recurrence that draws the boundary curve is off by 1e-4 "
        "(the drawn curve must be the exact one)",
    ),
    Mutant(
        "band-halved",
        "analyzer/simulation/_simulate.py",
        "        half = Z95 * self.stats.sem\n",
        "        half = Z95 * self.stats.sem / 2\n",
        ("tests/simulation/test_band.py",),
        "the 95% band of the Monte Carlo mean is half as wide as 1.96 s / sqrt(M)",
    ),
    Mutant(
        "filtered-band-halved",
        "analyzer/_json/_simulation.py",
        "    half = Z95 * f.sem\n",
        "    half = Z95 * f.sem / 2\n",
        ("tests/simulation/test_band.py",),
        "the 95% band of the filtered P(t|t) mean is half as wide as 1.96 s / sqrt(M)",
    ),
    Mutant(
        "float-binary-value",
        "analyzer/model/_exact.py",
        "        value = repr(float(value))",
        "        return Fraction(float(value))",
        ("tests/model/test_exact_edges.py",),
        "a Python float read through its binary value: parse_number(0.1) must be exactly 1/10",
    ),
    Mutant(
        "exponent-limit-inclusive",
        "analyzer/model/_exact.py",
        "abs(int(exp)) > 4 * max_digits:",
        "abs(int(exp)) >= 4 * max_digits:",
        ("tests/model/test_exact_edges.py",),
        "the exponent limit refuses its own edge: 0e800 and 0e-800 must be accepted",
    ),
    Mutant(
        "exponent-limit-past-edge",
        "analyzer/model/_exact.py",
        "abs(int(exp)) > 4 * max_digits:",
        "abs(int(exp)) > 4 * max_digits + 1:",
        ("tests/model/test_exact_edges.py",),
        "the exponent limit accepts one past its edge: 0e801 and 0e-801 must be refused",
    ),
    Mutant(
        "check-path-not-confined",
        "analyzer/check/_spec.py",
        "            if os.path.commonpath([real, root]) == root:\n",
        "            if True:\n",
        ("tests/check/test_check_confinement.py",),
        "a check file reads any path it names: ../../etc/passwd, absolute paths and symlinks out must be refused",
    ),
    Mutant(
        "values-not-withheld",
        "analyzer/model/_exact.py",
        "    if _WITHHELD.get():\n",
        "    if False:\n",
        ("tests/model/test_number_text.py", "tests/check/test_check_confinement.py"),
        "errors about a check's plant, channel and loop files quote their values (a credential the path led to)",
    ),
    Mutant(
        "echo-unclipped",
        "analyzer/errors.py",
        '    return text if len(text) <= limit else text[:limit] + "..."\n',
        "    return text\n",
        ("tests/model/test_number_text.py", "tests/service/test_error_bounds.py"),
        "errors quote a client's value whole: a 1 MB key gives a 2 MB error body",
    ),
    Mutant(
        "auth-first-token-only",
        "service/auth.py",
        "        return any([hmac.compare_digest(presented, t) for t in self._tokens])\n",
        "        return hmac.compare_digest(presented, self._tokens[0])\n",
        ("tests/service/test_auth.py",),
        "only the first configured token is accepted: a token file's other clients get 401",
    ),
    Mutant(
        "auth-readyz-open",
        "service/auth.py",
        'OPEN_PATHS = frozenset({"/healthz", "/", ',
        'OPEN_PATHS = frozenset({"/healthz", "/readyz", "/", ',
        ("tests/service/test_auth.py",),
        "a route other than /healthz, the page and the docs answers without a token",
    ),
)


def run(m: Mutant) -> str:
    """Apply ``m``, run its tests, restore the file; ``"killed"``, ``"SURVIVED"``, ``"stale"`` or ``"skipped"``."""
    if not m.path:
        return "skipped"
    path = ROOT / m.path
    original = path.read_bytes()
    text = original.decode("utf-8")
    if text.count(m.old) != 1:
        return "stale"
    stat = path.stat()
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1")
    cmd = [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *m.tests]
    try:
        path.write_text(text.replace(m.old, m.new), encoding="utf-8")
        done = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    finally:
        path.write_bytes(original)
        os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns))
    if done.returncode == 0:
        return "SURVIVED"
    if done.returncode == 1:
        return "killed"
    # 2: interrupted, 3: internal error, 4: usage error, 5: no tests collected
    return f"error (pytest exit {done.returncode})"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("names", nargs="*", help="mutants to run (default: all)")
    parser.add_argument("--list", action="store_true", help="list the mutants and exit")
    args = parser.parse_args(argv)
    known = {m.name: m for m in MUTANTS}
    if args.list:
        for m in MUTANTS:
            print(f"{m.name:34} {m.path or '-':36} {m.why}")
        return 0
    unknown = [n for n in args.names if n not in known]
    if unknown:
        parser.error(f"unknown mutant(s): {', '.join(unknown)}")
    chosen = [known[n] for n in args.names] if args.names else list(MUTANTS)
    results: dict[str, int] = {}
    for m in chosen:
        t0 = time.perf_counter()
        outcome = run(m)
        results[outcome] = results.get(outcome, 0) + 1
        print(f"{outcome:10} {m.name:34} {time.perf_counter() - t0:6.1f} s  {m.why}", flush=True)
    print("summary: " + ", ".join(f"{k} {v}" for k, v in sorted(results.items())))
    if results.get("stale"):
        return 2
    return 0 if set(results) <= {"killed", "skipped"} else 1


if __name__ == "__main__":
    sys.exit(main())
