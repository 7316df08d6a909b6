"""Peak memory of ``kfio simulate`` at n = 40: at most two batch copies in memory.

A script, not a test: ``python bench/bench_simulate_memory.py [--trajectories M]``.

Each run is a fresh child interpreter that simulates a 40-state plant for 5 steps with
``M`` trajectories (default 20,000, near the limit of 2^25 floats) and prints its peak
resident set (``ru_maxrss``). The same snippet runs against the code before this change
(``PREVIOUS_COMMIT``, via ``bench/_reference.py``) in the same run, and with ``M = 100``
for the interpreter's own footprint. One full ``(M, n, n)`` batch is ``M n^2 8`` bytes;
the table divides the peak above the footprint by it. The reports' JSON must agree
(compared by hash, timing fields aside).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _reference import ROOT, run_reference  # noqa: E402

#: main before the packed run kept one full batch at a time.
PREVIOUS_COMMIT = "73ba112"

SNIPPET = """
import hashlib, json, resource
import numpy as np
import kfio
n, M = 40, {M}
rng = np.random.default_rng(1)
A = (np.eye(n) * 0.9 + 0.01 * rng.standard_normal((n, n))).round(3)
req = {{"system": {{"A": A.tolist(), "C": [[1] + [0] * (n - 1)], "Q": np.eye(n).tolist(), "R": [[1]]}},
       "channel": {{"model": "bernoulli", "arrival_probability": 0.7}},
       "options": {{"simulate": {{"steps": 5, "trajectories": M, "seed": 1}}}}}}
d = kfio.simulate(kfio.parse_request(req)).to_dict()
d.pop("timing", None)
digest = hashlib.sha256(json.dumps(d, sort_keys=True, default=str).encode()).hexdigest()[:16]
print(json.dumps({{"peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, "digest": digest}}))
"""


def current(M: int) -> dict:
    import subprocess

    out = subprocess.run(
        [sys.executable, "-c", SNIPPET.format(M=M)],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trajectories", type=int, default=20_000)
    M = parser.parse_args().trajectories
    batch_mb = M * 40 * 40 * 8 / 2**20
    rows = []
    for name, run in (("now", current), ("before", lambda m: run_reference(SNIPPET.format(M=m), PREVIOUS_COMMIT))):
        base, big = run(100), run(M)
        rows.append((name, big["peak_mb"], (big["peak_mb"] - base["peak_mb"]) / batch_mb, big["digest"]))
    print(f"n = 40, {M} trajectories x 5 steps; one full batch = {batch_mb:.0f} MB\n")
    print("| code | peak RSS (MB) | batch copies above the interpreter | report digest |")
    print("|---|---|---|---|")
    for name, peak, copies, digest in rows:
        print(f"| {name} | {peak:.0f} | {copies:.2f} | `{digest}` |")
    print(f"\nratio before/now (peak): {rows[1][1] / rows[0][1]:.2f}x; same report: {rows[0][3] == rows[1][3]}")


if __name__ == "__main__":
    main()
