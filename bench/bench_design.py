"""Benchmark: design answers on top of ``analyze``.

* The exact Gilbert-Elliott (p, q) map on a 41 x 41 grid for seed systems
  (target: under 5 s), against ``analyze`` alone on the same request, and
  against the naive route of one full ``analyze`` per cell (measured on a few
  cells and scaled to 1681).
* The tail exponent: ``tail_report`` alone against the whole ``analyze``.

All timings in this one run, so ratios hold on a loaded machine.  Run:
``python bench/bench_design.py``.
"""

from __future__ import annotations

import json
import time

from kfio import analyze, load_request
from kfio.design._tail import tail_report
from kfio.sigma._sigma import compute_sigma
from kfio.stability._verdict import _channels_of
from kfio.structure._fmo import fmo_blocks

GE = {"model": "gilbert_elliott", "failure_rate": "1/4", "recovery_rate": "1/2"}
SYSTEMS = {
    "Rohr, Marelli and Fu (2014) Example (A = 1.25 diag(1, -1), C = [1 1])": ([["5/4", 0], [0, "-5/4"]], [[1, 1]]),
    "Sinopoli et al. (2004) 3x3 (A = [[1.25,1,0],[0,0.9,7],[0,0,0.6]])": (
        [[1.25, 1, 0], [0, 0.9, 7], [0, 0, 0.6]],
        [[1, 0, 2]],
    ),
    "period 6, two rows (1.1 x cyclic shift)": (
        [[("11/10" if (i - j) % 6 == 1 else 0) for j in range(6)] for i in range(6)],
        [[1, 0, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0]],
    ),
}


def timed(fn, repeat=3):
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def main() -> None:
    print("| system | analyze (s) | analyze + 41x41 GE map (s) | naive: analyze per cell, est. (s) | ratio |")
    print("|---|---|---|---|---|")
    for name, (A, C) in SYSTEMS.items():
        plain = load_request(json.dumps({"system": {"A": A, "C": C}, "channel": GE}))
        mapped = load_request(
            json.dumps({"system": {"A": A, "C": C}, "channel": GE, "options": {"analyze": {"ge_grid": 41}}})
        )
        t_plain, _ = timed(lambda r=plain: analyze(r))
        t_map, rep = timed(lambda r=mapped: analyze(r), repeat=1)
        cells = [
            load_request(
                json.dumps(
                    {
                        "system": {"A": A, "C": C},
                        "channel": {"model": "gilbert_elliott", "failure_rate": f"{p}/41", "recovery_rate": f"{q}/41"},
                    }
                )
            )
            for p, q in ((5, 7), (20, 30), (33, 11))
        ]
        t_cell = min(timed(lambda r=r: analyze(r), repeat=1)[0] for r in cells)
        naive = t_cell * 41 * 41
        assert len(rep.gilbert_elliott.map.labels) == 41
        print(f"| {name} | {t_plain:.3f} | {t_map:.3f} | {naive:.1f} | {naive / t_map:.0f}x |")
    print()
    print("| system, channel | analyze (s) | tail_report alone (s) | share |")
    print("|---|---|---|---|")
    for name, (A, C) in SYSTEMS.items():
        for ch in (GE, {"model": "bernoulli", "arrival_probability": "1/2"}):
            req = load_request(json.dumps({"system": {"A": A, "C": C}, "channel": ch}))
            t_all, _ = timed(lambda r=req: analyze(r))
            channels = _channels_of(req)
            blocks = fmo_blocks(req.system)
            items = [(b, compute_sigma(b.phase, channels) if b.modulus_sq_float >= 1 else None) for b in blocks]
            t_tail, _ = timed(lambda i=items, c=channels: tail_report(i, c))
            print(f"| {name}, {ch['model']} | {t_all:.3f} | {t_tail:.4f} | {100 * t_tail / t_all:.1f} % |")


if __name__ == "__main__":
    main()
