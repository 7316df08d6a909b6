"""CPU of building the JSON of a report: the one encoder of kfio._json against the per-class to_dict methods.

The reference is main before the JSON moved to ``kfio._json`` (commit ``7299885``), run in a child
interpreter on the same reports (bench/_reference.py).  Each line times ``to_dict()`` and ``to_json()``
of one report (CPU, ``time.process_time``, best of 5 rounds of ``reps`` calls) and checks that both
codes print the same text, byte for byte.

    .venv/bin/python bench/bench_json.py
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _reference import run_reference  # noqa: E402

REFERENCE = "7299885"

#: (label, command, request, reps): the reports whose JSON is timed.
CASES = [
    (
        "analyze, Gilbert-Elliott with a 24 x 24 map",
        "analyze",
        {
            "system": {"A": [["5/4", 0], [0, "-5/4"]], "C": [[1, 1]]},
            "channel": {"model": "gilbert_elliott", "failure_rate": "1/4", "recovery_rate": "1/2"},
            "options": {"analyze": {"ge_grid": 24}},
        },
        200,
    ),
    (
        "analyze, two Bernoulli sensors (regions, boundary curve)",
        "analyze",
        {
            "system": {
                "A": [[1.25, 0], [1, 1.1]],
                "C": [[1, 0], [1, 1]],
                "sensors": [{"name": "first", "rows": [0]}, {"name": "second", "rows": [1]}],
            },
            "channel": {
                "model": "per_sensor",
                "channels": {
                    "first": {"model": "bernoulli", "arrival_probability": 0.25},
                    "second": {"model": "bernoulli", "arrival_probability": 0.25},
                },
            },
        },
        500,
    ),
    (
        "bounds, two sensors, 11 x 11 region map",
        "bounds",
        {
            "system": {
                "A": [[1.25, 0], [1, 1.1]],
                "C": [[1, 0], [1, 1]],
                "Q": [[20, 0], [0, 20]],
                "R": [[2.5, 0], [0, 2.5]],
                "sensors": [{"name": "first", "rows": [0]}, {"name": "second", "rows": [1]}],
            },
            "channel": {
                "model": "per_sensor",
                "channels": {
                    "first": {"model": "bernoulli", "arrival_probability": 0.25},
                    "second": {"model": "bernoulli", "arrival_probability": 0.25},
                },
            },
            "options": {"bounds": {"grid": 11}},
        },
        500,
    ),
    (
        "simulate, 5000 steps (series of 5001 floats), exact E[P_t] to 8",
        "simulate",
        {
            "system": {"A": [[1.3]], "C": [[1]], "Q": [[1]], "R": [[1]]},
            "channel": {"model": "bernoulli", "arrival_probability": 0.5},
            "options": {"simulate": {"steps": 5000, "trajectories": 200, "seed": 1, "exact_steps": 8}},
        },
        20,
    ),
]

SNIPPET = """
import hashlib, json, time
from kfio import analyze, load_request
from kfio.riccati_bounds._compute import compute_bounds
from kfio.simulation._simulate import simulate
RUN = {"analyze": analyze, "bounds": compute_bounds, "simulate": simulate}
out = []
for command, body, reps in json.loads(CASES):
    rep = RUN[command](load_request(json.dumps(body)))
    best = {}
    for what, fn in (("to_dict", rep.to_dict), ("to_json", rep.to_json)):
        times = []
        for _ in range(5):
            t0 = time.process_time()
            for _ in range(reps):
                fn()
            times.append((time.process_time() - t0) / reps)
        best[what] = min(times)
    out.append({**best, "sha": hashlib.sha256(rep.to_json().encode()).hexdigest(), "bytes": len(rep.to_json())})
print(json.dumps(out))
"""


def _run_here(code: str) -> list[dict]:
    scope: dict = {}
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        exec(code, scope)  # the same snippet as the reference runs, in this interpreter
    return json.loads(buf.getvalue().strip().splitlines()[-1])


def main() -> None:
    cases = json.dumps([[c, b, r] for _, c, b, r in CASES])
    code = f"CASES = {cases!r}\n" + SNIPPET
    new = _run_here(code)
    old = run_reference(code, commit=REFERENCE)
    print(f"JSON of a report, CPU per call (best of 5); reference: main at {REFERENCE} (one to_dict per class)")
    print(
        f"{'report':62} {'bytes':>8} {'to_dict old':>12} {'new':>10} {'ratio':>6} {'to_json old':>12} {'new':>10}  same text"
    )
    for (label, *_), a, b in zip(CASES, old, new):
        same = "yes" if a["sha"] == b["sha"] else "NO"
        print(
            f"{label:62} {b['bytes']:8d} {1e3 * a['to_dict']:10.3f}ms {1e3 * b['to_dict']:8.3f}ms "
            f"{b['to_dict'] / a['to_dict']:6.2f} {1e3 * a['to_json']:10.3f}ms {1e3 * b['to_json']:8.3f}ms  {same}"
        )


if __name__ == "__main__":
    main()
