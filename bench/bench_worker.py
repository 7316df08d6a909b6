"""Worker CPU per uncached analysis, the cost behind the service's uncached latency (issue 15, item 3).

    python bench/bench_worker.py [--before CHECKOUT] [--requests 300]

What a service worker runs for ``POST /v1/analyze`` (:func:`kfio.service.jobs.run_job`: parse,
analyze, the ``--json`` text) is timed in a warm process (after the forkserver's warm-up
module), CPU ms per request, over the three one-packet seed systems of the API examples:

* ``new channel``: every request has an arrival probability never sent before (the answer
  cache misses; the plant is one of three, as in ``bench_service.py``'s ``analyze-uncached``);
* ``new plant``: ``A[0][0]`` changes too, so nothing about the request was seen before.

With ``--before`` (a folder holding an older checkout's ``analyzer/`` and ``service/``, e.g.
``mkdir /tmp/before && git archive <commit> analyzer service | tar -x -C /tmp/before``) the same
requests run on that code in the same run, and the ratio is printed.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

CHILD = r"""
import json, statistics, sys, time
import kfio.service.warmup  # noqa: F401 - what the forkserver preloads
from kfio.service.jobs import run_job
from kfio.service.settings import get_settings
settings = get_settings()
groups = json.loads(sys.stdin.read())
out = {}
for name, bodies in groups.items():
    times = []
    for i, body in enumerate(bodies):
        t = time.process_time()
        res = run_job("analyze", body.encode(), settings, {}, 30.0)
        times.append(time.process_time() - t)
        assert res[0] == "ok", res
    times = sorted(times[10:])  # the first ten warm the caches of this group
    out[name] = [1000 * statistics.median(times), 1000 * times[int(0.9 * len(times))]]
print(json.dumps(out))
"""


def bodies(count: int) -> dict[str, list[str]]:
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    from kfio.service.api.schemas import REQUEST_EXAMPLES

    seeds = [REQUEST_EXAMPLES[k]["value"] for k in ("seed004-scalar", "seed004-3x3", "seed002-2x2")]
    groups: dict[str, list[str]] = {"new channel": [], "new plant": []}
    for i in range(count):
        for name in groups:
            body = json.loads(json.dumps(seeds[i % 3]))
            body["channel"]["arrival_probability"] = f"{600000 + i}/1000000"
            if name == "new plant":
                A = body["system"]["A"]
                A[0][0] = f"{A[0][0]}{1 + i}" if isinstance(A[0][0], str) and "." in A[0][0] else f"{1000 + i}/1000"
            groups[name].append(json.dumps(body))
    return groups


def tree_of(checkout: str) -> str:
    """A folder whose ``kfio`` package is ``checkout``'s ``analyzer/`` with its ``service/`` inside."""
    root = tempfile.mkdtemp(prefix="kfio-before-")
    pkg = os.path.join(root, "kfio")
    os.mkdir(pkg)
    src = os.path.join(os.path.abspath(checkout), "analyzer")
    for entry in os.listdir(src):
        os.symlink(os.path.join(src, entry), os.path.join(pkg, entry))
    os.symlink(os.path.join(os.path.abspath(checkout), "service"), os.path.join(pkg, "service"))
    return root


def run(groups: dict[str, list[str]], pythonpath: str | None) -> dict[str, list[float]]:
    env = dict(os.environ)
    if pythonpath:
        env["PYTHONPATH"] = pythonpath
    res = subprocess.run(
        [sys.executable, "-c", CHILD], input=json.dumps(groups), capture_output=True, text=True, env=env, check=True
    )
    return json.loads(res.stdout.strip().splitlines()[-1])  # type: ignore[no-any-return]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", help="older checkout holding analyzer/ and service/")
    ap.add_argument("--requests", type=int, default=300)
    args = ap.parse_args()
    groups = bodies(args.requests)
    now = run(groups, None)
    old = run(groups, tree_of(args.before)) if args.before else None
    print(f"load average {os.getloadavg()[0]:.1f}; CPU ms per request (median, p90), {args.requests} requests each")
    print("| requests | now | before | ratio (median) |")
    print("|---|---|---|---|")
    for name, (med, p90) in now.items():
        before = ratio = ""
        if old is not None:
            before = f"{old[name][0]:.2f} / {old[name][1]:.2f}"
            ratio = f"{old[name][0] / med:.1f}x"
        print(f"| {name} | {med:.2f} / {p90:.2f} | {before} | {ratio} |")


if __name__ == "__main__":
    main()
