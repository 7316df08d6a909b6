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
        ("tests/service/plots/test_plot_ge_boundary.py",),
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
        "elia-first-unstable-only",
        "analyzer/loop/_lqg_critical.py",
        "                if r2 > 1:\n                    exact *= r2**mult\n",
        "                if r2 > 1 and exact == 1:\n                    exact *= r2**mult\n",
        ("tests/loop/test_loop_lqg_optimal.py",),
        "Elia's product over the unstable eigenvalues stops at the first one: 57/121 becomes 9/25",
    ),
    Mutant(
        "schur-cohn-circle-inside",
        "analyzer/loop/_lqg_critical.py",
        "        if abs(a0) >= abs(ad):\n",
        "        if abs(a0) > abs(ad):\n",
        ("tests/loop/test_loop_lqg_optimal.py",),
        "a root on the unit circle counted as stable: an uncontrollable mode at 1 or -1 would be stabilizable",
    ),
    Mutant(
        "lqg-filter-gain-in-predictor-form",
        "analyzer/loop/_lqg.py",
        '    K = K_f if req.form == "filter" else A @ K_f\n',
        "    K = A @ K_f\n",
        ("tests/loop/test_loop_lqg_optimal.py",),
        "the stationary LQG estimator gain always in predictor form: the filter-form cost is no longer J_max",
    ),
    Mutant(
        "certify-definite-uncertain",
        "analyzer/loop/_certify.py",
        "        if not s > zero:\n",
        "        if s < zero:\n",
        ("tests/loop/test_loop_certified.py",),
        "the definiteness proof accepts a row whose Gershgorin margin is only possibly positive (a ball around 0)",
    ),
    Mutant(
        "certify-cost-width-dropped",
        "analyzer/loop/_certify.py",
        "    width = e.upper() * lin_y.upper()\n",
        "    width = 0 * lin_y.upper()\n",
        ("tests/loop/test_loop_certified.py",),
        "the cost enclosure forgets the float solve's error: only the rounding of J(X_hat) is enclosed",
    ),
    Mutant(
        "gain-letters-accepted-silently",
        "analyzer/loop/_model.py",
        "            if letter in gains:\n",
        "            if letter in gains and letter not in gains:\n",
        ("tests/loop/test_loop_doors.py",),
        "controller.gains K/L no longer refused with the explanation of which gain is which",
    ),
    Mutant(
        "check-interval-left-end-ignored",
        "analyzer/check/_requirements.py",
        '    return Judgement("pass" if above and below else "fail", measured, detail)\n',
        '    return Judgement("pass" if below else "fail", measured, detail)\n',
        ("tests/check/test_check_loop.py",),
        "a limit below a UDP loop's stable interval passes: the interval's left end is not compared",
    ),
    Mutant(
        "check-interval-not-at-request",
        "analyzer/check/_requirements.py",
        "    home = [(a, b) for a, b in stable if at is not None and a < at < b]\n",
        "    home = stable\n",
        ("tests/check/test_check_loop.py",),
        "a stable interval that does not hold the request's point stands for the critical value",
    ),
    Mutant(
        "summary-degree-off-by-one",
        "service/commands/loop.py",
        '            degree = c.get("value_minimal_polynomial_degree")  # known also when the coefficients are capped\n',
        '            degree = len(c["value_minimal_polynomial"] or []) or None\n',
        ("tests/loop/test_loop_summary.py",),
        "the summary names a critical value's degree as its number of coefficients",
    ),
    Mutant(
        "loop-operator-blocks-transposed",
        "analyzer/loop/_operator.py",
        "T[j * s + r, i * s + c] = p * srow[c]",
        "T[i * s + r, j * s + c] = p * srow[c]",
        ("tests/loop/test_loop_multimode_oracle.py",),
        "the exact operator's block (j, i) written at (i, j): the multi-mode cost and verdict must match the "
        "independent full-vec float operator",
    ),
    Mutant(
        "loop-transition-transposed",
        "analyzer/loop/_operator.py",
        "            p = _fq(sys.P[i][j])\n",
        "            p = _fq(sys.P[j][i])\n",
        ("tests/loop/test_loop_multimode_oracle.py",),
        "the exact operator weighs block (j, i) by p_ji instead of p_ij (Gilbert-Elliott chains are not symmetric)",
    ),
    Mutant(
        "loop-noise-without-mode-weight",
        "analyzer/loop/_operator.py",
        "        per_mode.append(_fq(sys.pi[i]) * acc)\n",
        "        per_mode.append(acc)\n",
        ("tests/loop/test_loop_multimode_oracle.py",),
        "the noise forcing of the stationary moments without the mode's stationary probability pi_i",
    ),
    Mutant(
        "loop-ge-table-swapped",
        "analyzer/design/_critical_parameter.py",
        'rest == ["recovery_rate"]:\n        return (0,), False, chan.table[0]\n',
        'rest == ["recovery_rate"]:\n        return (1,), False, chan.table[1]\n',
        ("tests/loop/test_loop_multimode_oracle.py",),
        "a Gilbert-Elliott link's recovery rate put where the arrival after an arrival belongs: the critical "
        "recovery rates must match bisection",
    ),
    Mutant(
        "loop-cost-input-noise-dropped",
        "analyzer/loop/_cost.py",
        "            total += w * pi * _trace(sys.U * br.Ea * sys.Sigma * br.Ea.transpose())\n",
        "",
        ("tests/loop/test_loop_multimode_oracle.py",),
        "the cost term pi tr(U Ea Sigma Ea') dropped: in filter form the applied input carries measurement noise",
    ),
    Mutant(
        "loop-definite-tolerance-sign",
        "analyzer/model/_request.py",
        "    if lam > tol:\n",
        "    if lam > -tol:\n",
        ("tests/loop/test_loop_multimode_oracle.py",),
        "the float definiteness filter calls a barely indefinite matrix positive definite instead of deciding it "
        "exactly",
    ),
    Mutant(
        "loop-definite-negative-as-positive",
        "analyzer/model/_request.py",
        "    if lam < -tol:\n        return -1\n",
        "    if lam < -tol:\n        return 1\n",
        ("tests/loop/test_loop_multimode_oracle.py",),
        "the float definiteness filter reports a clearly indefinite matrix as positive definite",
    ),
    Mutant(
        "loop-interval-left-end-off-by-one",
        "analyzer/loop/_critical.py",
        "            merged.append((edges[k][1], edges[k + 1][1], lab))\n",
        "            merged.append((edges[k - 1][1], edges[k + 1][1], lab))\n",
        ("tests/loop/test_loop_multimode_oracle.py",),
        "each interval of a link's range starts one root too early: its ends must match bisection",
    ),
    Mutant(
        "loop-merged-right-end-off-by-one",
        "analyzer/loop/_critical.py",
        "            merged[-1] = (merged[-1][0], edges[k + 1][1], lab)\n",
        "            merged[-1] = (merged[-1][0], edges[k][1], lab)\n",
        ("tests/loop/test_loop_multimode_oracle.py",),
        "an interval merged across a root where another eigenvalue crosses 1 ends one root too early",
    ),
    Mutant(
        "fit-bonferroni-dropped",
        "analyzer/fit/_fit.py",
        "    each = float(bonferroni_level(lvl, m))\n",
        "    each = float(lvl)\n",
        ("tests/fit/test_fit_estimates.py",),
        "the joint box of a fitted channel built from intervals at the joint level, not 1 - (1 - level) / m each",
    ),
    Mutant(
        "fit-history-bits-reversed",
        "analyzer/fit/_estimate.py",
        "        h |= a[first - j : a.size - j] << (j - 1)\n",
        "        h |= a[first - j : a.size - j] << (order - j)\n",
        ("tests/fit/test_fit_estimates.py",),
        "Markov histories counted newest packet first, not in kfio's oldest-first table convention",
    ),
    Mutant(
        "fit-worst-corner-flipped",
        "analyzer/fit/_confidence.py",
        '    return name == "failure_rate"\n',
        '    return name != "failure_rate"\n',
        ("tests/fit/test_fit_confidence.py",),
        "the worst corner of the confidence box takes the highest arrival probabilities",
    ),
    Mutant(
        "fit-samples-needed-linear",
        "analyzer/fit/_confidence.py",
        "    return math.ceil(samples / (good * good))\n",
        "    return math.ceil(samples / good)\n",
        ("tests/fit/test_fit_confidence.py",),
        "samples_needed with half-widths shrinking like 1/N instead of 1/sqrt(N)",
    ),
    Mutant(
        "lane-takes-one-state-more",
        "service/lanes.py",
        "len(matrix) > MAX_STATES:",
        "len(matrix) > MAX_STATES + 1:",
        ("tests/service/jobs/test_lanes.py",),
        "the cheap lane takes a request one state past its size rule",
    ),
    Mutant(
        "restart-runs-once-more",
        "service/jobstore.py",
        "if job.attempts >= MAX_RUNS:",
        "if job.attempts > MAX_RUNS:",
        ("tests/service/jobs/test_jobs_durable.py",),
        "a job found running after MAX_RUNS server deaths is run again instead of failing interrupted-by-restart",
    ),
    Mutant(
        "whole-body-to-slow-readers",
        "service/connection_guard.py",
        "            if len(body) <= self.chunk_bytes:\n",
        "            if True:\n",
        ("tests/service/server/test_slow_readers.py",),
        "a large response body handed to the server whole: a slow reader holds all of it",
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
        ("tests/model/test_number_text.py", "tests/service/http/test_error_bounds.py"),
        "errors quote a client's value whole: a 1 MB key gives a 2 MB error body",
    ),
    Mutant(
        "auth-first-token-only",
        "service/auth.py",
        "        return any([hmac.compare_digest(presented, t) for t in self._tokens])\n",
        "        return hmac.compare_digest(presented, self._tokens[0])\n",
        ("tests/service/server/test_auth.py",),
        "only the first configured token is accepted: a token file's other clients get 401",
    ),
    Mutant(
        "auth-readyz-open",
        "service/auth.py",
        'OPEN_PATHS = frozenset({"/healthz", "/", ',
        'OPEN_PATHS = frozenset({"/healthz", "/readyz", "/", ',
        ("tests/service/server/test_auth.py",),
        "a route other than /healthz, the page and the docs answers without a token",
    ),
    Mutant(
        "host-wildcard-suffix",
        "service/host_check.py",
        "name.endswith(h[1:])",
        "name.endswith(h[2:])",
        (
            "tests/service/server/test_service_hosts.py",
            "tests/service/server/test_host_patterns.py",
            "tests/test_doctests.py",
        ),
        "'*.example.org' trusts 'example.org' and 'evilexample.org' too, not only its subdomains",
    ),
    Mutant(
        "worker-memory-unlimited",
        "analyzer/_workers.py",
        "    resource.setrlimit(resource.RLIMIT_AS, (limit, hard))\n",
        "    del limit\n",
        ("tests/service/cli/test_cli_watchdog.py", "tests/check/test_check_cli.py", "tests/test_workers.py"),
        "the shared worker mechanics set no address-space limit: a runaway allocation takes the machine",
    ),
    Mutant(
        "sweep-chunk-past-table",
        "analyzer/sweep/_spec.py",
        "int(chunk_field.maximum or 0))",
        "int(chunk_field.maximum or 0) + 1)",
        ("tests/model/test_fields.py",),
        "the sweep parser admits one more than the option table (and the published schema) allows",
    ),
    Mutant(
        "sweep-budget-ignored",
        "analyzer/sweep/_api.py",
        "        parsed = dataclasses.replace(parsed, time_budget_s=seconds)\n",
        "        parsed = parsed\n",
        ("tests/api/test_api_shape.py",),
        "kfio.sweep(..., budget=) runs on the file's budget, ignoring the argument",
    ),
    Mutant(
        "cache-entries-unbounded",
        "service/cache.py",
        "        while len(self) > self.max_entries:\n",
        "        while len(self) > self.max_entries + 1:\n",
        ("tests/service/http/test_service_units.py", "tests/test_doctests.py"),
        "the answer cache keeps one entry more than KFIO_CACHE_ENTRIES",
    ),
    Mutant(
        "check-unfinished-not-budget",
        "analyzer/check/_run.py",
        '                        "budget-exceeded",\n',
        '                        "internal",\n',
        ("tests/check/test_check_cli.py", "tests/api/test_api_shape.py"),
        "a check run the budget cut off is reported as an internal error, not budget-exceeded (exit code)",
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
