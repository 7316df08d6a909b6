"""Warm a worker before its first request: imported by the forkserver (``PRELOAD``), it runs tiny analyses.

Importing :mod:`kfio` does not import everything a request touches: SymPy loads sub-modules
(polys domains, the algebraic-number code, root isolation) and fills caches on first use, and
CVXPY compiles its first problem.  A fresh worker used to pay that on its first request (about
0.03-0.13 s of CPU).  Running one small request of each kind here, once in the forkserver,
means every forked worker, a replacement too, inherits the loaded modules and the warm caches.

A failure here is logged and ignored: warming is an optimisation, never a reason not to serve.
"""

from __future__ import annotations

import logging
import time

log = logging.getLogger("kfio.service")

#: Tiny requests covering the paths of the seed systems: a real unstable mode, a complex pair
#: with a Markov channel, two sensors per-sensor; and one bounds request (CVXPY's first solve).
WARMUP_ANALYZE = (
    b'{"system": {"A": [[1.25, 1], [0, 0.9]], "C": [[1, 0]]},'
    b' "channel": {"model": "bernoulli", "arrival_probability": 0.5}}',
    b'{"system": {"A": [[0.5, -1.2, 0], [1.2, 0.5, 0], [0, 0, 1.1]], "C": [[1, 0, 1]]},'
    b' "channel": {"model": "gilbert_elliott", "failure_rate": "1/4", "recovery_rate": "1/2"}}',
    b'{"system": {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 0], [1, 1]],'
    b' "sensors": [{"name": "one", "rows": [0]}, {"name": "two", "rows": [1]}]},'
    b' "channel": {"model": "per_sensor", "channels": {"one": {"model": "bernoulli", "arrival_probability": 0.7},'
    b' "two": {"model": "bernoulli", "arrival_probability": "3/5"}}}}',
)
WARMUP_BOUNDS = (
    b'{"system": {"A": [[-1.25]], "C": [[1]], "Q": [[1]], "R": [[2.5]]},'
    b' "channel": {"model": "bernoulli", "arrival_probability": 0.4}}'
)


def warm() -> float:
    """Run the warm-up requests; returns the CPU seconds spent (0 if something failed)."""
    from kfio import analyze, load_request
    from kfio.riccati_bounds import compute_bounds

    start = time.process_time()
    try:
        for body in WARMUP_ANALYZE:
            analyze(load_request(body))
        compute_bounds(load_request(WARMUP_BOUNDS))
    except Exception:  # noqa: BLE001  # warming must never keep the service from starting
        log.warning("worker warm-up failed; workers will warm on their first requests", exc_info=True)
        return 0.0
    return time.process_time() - start


WARMUP_CPU_SECONDS = warm()
