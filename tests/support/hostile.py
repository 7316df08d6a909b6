"""Hostile bodies and probes against the service (loopback only), shared by tests and ``bench/bench_hostile.py``."""

from __future__ import annotations

import json
from typing import Any

#: The 2x2 system of Sinopoli et al. (2004) (stable at 1/2, critical probability 9/25).
SMALL = {
    "system": {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]], "Q": [[20, 0], [0, 20]], "R": [[2.5]]},
    "channel": {"model": "bernoulli", "arrival_probability": 0.5},
}


def heavy_sweep(points: int = 100_000, seed: int = 0, time_budget_s: float | None = None) -> bytes:
    """A sweep whose every point is slow to validate: a 40 x 40 near-singular exact ``Q``.

    ``Q = J + 10^-9 I`` (``J`` all ones) is positive definite with eigenvalues
    ``40 + 10^-9`` and ``10^-9``: its exact check costs about 0.1 s a point
    here, so 100,000 points are hours of validation, in a body of 24 KB.
    ``seed`` shifts the range so that bodies differ.
    """
    n = 40
    eye = [[1 if i == j else 0 for j in range(n)] for i in range(n)]
    q = [["1.000000001" if i == j else "1" for j in range(n)] for i in range(n)]
    a = [["101/100" if i == j else ("1/10" if j == i + 1 else 0) for j in range(n)] for i in range(n)]
    base = {
        "system": {"A": a, "C": eye, "Q": q, "R": eye},
        "channel": {"model": "bernoulli", "arrival_probability": 0.5},
    }
    axis = {"pointer": "/channel/arrival_probability", "from": f"1/{10 + seed}", "to": "9/10", "num": points}
    doc: dict[str, Any] = {"command": "analyze", "base": base, "axes": [axis]}
    if time_budget_s is not None:
        doc["options"] = {"time_budget_s": time_budget_s}
    return json.dumps(doc).encode()


def wide_sweep(n_axes: int = 150, num: int = 100_000) -> bytes:
    """``n_axes`` range axes of ``num`` values (12.8 KB for 150): ``num^n_axes`` points, refused by size."""
    axis = {"pointer": "/channel/arrival_probability", "from": "1/10", "to": "9/10", "num": num}
    axes = [{**axis, "name": f"p{i}"} for i in range(n_axes)]
    return json.dumps({"command": "analyze", "base": SMALL, "axes": axes}).encode()


def values_sweep(n_axes: int = 14_300) -> bytes:
    """``n_axes`` axes of two listed values (about 750 KB for 14,300): ``2^n_axes`` points.

    Cheap to build even for code that builds every axis first, so the
    earlier code reaches its message: ``2^14300`` has 4,305 digits, which
    Python refuses to print (it was a 500).
    """
    axes = [{"pointer": "/system/A", "name": f"a{i}", "values": [0, 1]} for i in range(n_axes)]
    return json.dumps({"command": "analyze", "base": SMALL, "axes": axes}, separators=(",", ":")).encode()


def rss_mb(pid: int) -> float:
    """Resident memory of process ``pid`` in MiB (``VmRSS`` of ``/proc``)."""
    with open(f"/proc/{pid}/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    raise RuntimeError(f"no VmRSS for process {pid}")
