"""Worker CPU per uncached analysis, the cost behind the service's uncached latency.

    python bench/bench_worker.py [--reference COMMIT] [--requests 300]

What a service worker runs for ``POST /v1/analyze`` (:func:`kfio.service.jobs.run_job`: parse,
analyze, the ``--json`` text) is timed in a warm process (after the forkserver's warm-up
module), CPU ms per request, over the three one-packet seed systems of the API examples:

* ``new channel``: every request has an arrival probability never sent before (the answer
  cache misses; the plant is one of three, as in ``bench_service.py``'s ``analyze-uncached``);
* ``new plant``: ``A[0][0]`` changes too, so nothing about the request was seen before.

The same requests run on the code of ``--reference`` (default ``7299885``) in a child
interpreter (:mod:`_reference`), in the same run, and the ratio is printed.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _reference import run_reference  # noqa: E402


def measure(path: str) -> dict[str, list[float]]:
    """CPU ms (median, p90) per request of every group of bodies in the JSON file ``path``.

    Runs with whichever ``kfio`` is importable: this checkout's, or the reference's in its child.
    """
    import statistics
    import time

    import kfio.service.warmup  # noqa: F401 - what the forkserver preloads
    from kfio.service.jobs import run_job
    from kfio.service.settings import get_settings

    settings = get_settings()
    with open(path) as f:
        groups = json.load(f)
    out = {}
    for name, bodies in groups.items():
        times = []
        for body in bodies:
            t = time.process_time()
            res = run_job("analyze", body.encode(), settings, {}, 30.0)
            times.append(time.process_time() - t)
            assert res[0] == "ok", res
        times = sorted(times[10:])  # the first ten warm the caches of this group
        out[name] = [1000 * statistics.median(times), 1000 * times[int(0.9 * len(times))]]
    return out


def bodies(count: int) -> dict[str, list[str]]:
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reference", default="7299885", help="commit whose code is timed beside this one")
    ap.add_argument("--requests", type=int, default=300)
    args = ap.parse_args()
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        json.dump(bodies(args.requests), f)
    try:
        bench = str(Path(__file__).resolve().parent)
        child = f"import json, sys; sys.path.insert(0, {bench!r}); from bench_worker import measure\n"
        old = run_reference(child + f"print(json.dumps(measure({f.name!r})))", args.reference)
        now = measure(f.name)
    finally:
        os.unlink(f.name)
    print(f"load average {os.getloadavg()[0]:.1f}; CPU ms per request (median, p90), {args.requests} requests each")
    print(f"| requests | now | {args.reference} | ratio (median) |")
    print("|---|---|---|---|")
    for name, (med, p90) in now.items():
        before = old[name]
        print(f"| {name} | {med:.2f} / {p90:.2f} | {before[0]:.2f} / {before[1]:.2f} | {before[0] / med:.1f}x |")


if __name__ == "__main__":
    main()
