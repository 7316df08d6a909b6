"""Uncached ``analyze`` at FLINT speed: new random 3x3 plants and dense plants up to n = 120.

    python bench/bench_analyze_speed.py [--reference 13e923d] [--plants 60] [--sizes 40,80,120]

Two measurements, CPU time of this process (``time.process_time``), each run on this checkout
and, in the same run, on the code of ``--reference`` in a child interpreter (:mod:`_reference`):

* ``new 3x3 plant``: what a service worker does for ``POST /v1/analyze`` (parse, analyze, JSON
  text; :func:`kfio.service.jobs.run_job`) for random 3x3 plants never seen before (entries
  ``k/100``, one output), median over ``--plants`` requests after 5 warm-up ones;
* ``dense n``: :func:`kfio.analyze` of one dense random plant (entries ``k/100``, one output) of
  each size, parsed with the state limit lifted so that sizes above it can be timed.

The answers of both codes are compared too (``same answer``: the JSON text of every request).
"""

from __future__ import annotations

import argparse
import json
import os
import random
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _reference import run_reference  # noqa: E402


def plant(n: int, seed: int) -> dict:
    """A random plant: ``A`` with entries ``k/100``, ``|k| <= 150`` (dense; spectral radius near 1 to n/2)."""
    rng = random.Random(seed)
    A = [[f"{rng.randint(-150, 150) / 100}" for _ in range(n)] for _ in range(n)]
    C = [[f"{rng.randint(-10, 10) / 10}" for _ in range(n)]]
    return {
        "system": {"A": A, "C": C},
        "channel": {"model": "bernoulli", "arrival_probability": "0.5"},
        "options": {"time_budget_s": 3000},
    }


def measure(plants: int, sizes: list[int]) -> dict:
    """CPU ms of the new-plant group (median) and CPU s per dense size, with a digest of every answer."""
    import hashlib
    import statistics
    import time

    import kfio.service.warmup  # noqa: F401 - what the forkserver preloads
    from kfio import analyze, load_request
    from kfio.model._limits import Limits
    from kfio.service.jobs import run_job
    from kfio.service.settings import get_settings

    settings = get_settings()
    digest = hashlib.sha256()
    times = []
    for i in range(plants + 5):
        body = json.dumps(plant(3, 10_000 + i)).encode()
        t = time.process_time()
        res = run_job("analyze", body, settings, {}, 30.0)
        times.append(time.process_time() - t)
        digest.update(repr(res).encode())
    out: dict = {"new 3x3 plant": 1000 * statistics.median(times[5:])}
    lifted = Limits(max_states=max(sizes + [40]), max_outputs=max(sizes + [40]))
    for n in sizes:
        text = json.dumps(plant(n, n))
        t = time.process_time()
        report = analyze(load_request(text, lifted))
        out[f"dense n = {n}"] = time.process_time() - t
        digest.update(json.dumps(report.to_dict(), sort_keys=True, default=str).encode())
    out["digest"] = digest.hexdigest()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reference", default="13e923d", help="commit whose code is timed beside this one")
    ap.add_argument("--plants", type=int, default=60)
    ap.add_argument("--sizes", default="40,80,120")
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",") if s]
    bench = str(Path(__file__).resolve().parent)
    child = f"import json, sys; sys.path.insert(0, {bench!r}); from bench_analyze_speed import measure\n"
    old = run_reference(child + f"print(json.dumps(measure({args.plants}, {sizes})))", args.reference)
    now = measure(args.plants, sizes)
    print(f"load average {os.getloadavg()[0]:.1f}; CPU time (time.process_time), same run")
    print(f"| work | now | {args.reference} | ratio |")
    print("|---|---|---|---|")
    for key in now:
        if key == "digest":
            continue
        unit = "ms" if key.startswith("new") else "s"
        print(f"| {key} | {now[key]:.3g} {unit} | {old[key]:.3g} {unit} | {old[key] / now[key]:.1f}x |")
    print(f"same answers (JSON of every request): {now['digest'] == old['digest']}")


if __name__ == "__main__":
    main()
