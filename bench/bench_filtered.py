"""Cost of the filtered covariance P(t|t) inside ``kfio simulate``.

Times :func:`kfio.simulation._simulate.run_monte_carlo` (predictor and
filtered statistics) and, in the same run, the filtered update alone applied
``T + 1`` times to a batch of the same size (the part the filtered report
adds). Prints the share of the run spent on the filtered covariance.
"""

from __future__ import annotations

import time

import numpy as np

from kfio import load_request
from kfio.simulation._filtered import filtered_covariance
from kfio.simulation._setup import parse_options, sim_system
from kfio.simulation._simulate import run_monte_carlo

CASES = {
    "scalar a = 1.2, lambda = 0.5": ([[1.2]], [[1]]),
    "3x3 Sinopoli et al. (2004)": ([[1.25, 1, 0], [0, 0.9, 7], [0, 0, 0.6]], [[1, 0, 2]]),
}


def main() -> None:
    import json

    for name, (A, C) in CASES.items():
        n = len(A)
        req = load_request(
            json.dumps(
                {
                    "system": {"A": A, "C": C, "Q": np.eye(n).tolist(), "R": [[1]]},
                    "channel": {"model": "bernoulli", "arrival_probability": 0.7},
                    "options": {"simulate": {"steps": 200, "trajectories": 5000, "seed": 1}},
                }
            )
        )
        sim, opts = sim_system(req), parse_options(req)
        t0 = time.perf_counter()
        run_monte_carlo(sim, opts)
        total = time.perf_counter() - t0
        P = np.broadcast_to(np.eye(n), (opts.trajectories, n, n)).copy()
        mask = (np.random.default_rng(0).random((opts.trajectories, 1)) < 0.7).astype(float)
        t0 = time.perf_counter()
        for _ in range(opts.steps + 1):
            filtered_covariance(P, sim.C, sim.R, mask)
        alone = time.perf_counter() - t0
        print(f"{name}: run {total:.3f} s, filtered update alone {alone:.3f} s ({100 * alone / total:.0f}% of the run)")


if __name__ == "__main__":
    main()
