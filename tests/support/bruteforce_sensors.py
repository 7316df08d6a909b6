"""Independent brute force of the per-sensor blind probability, from the raw ``(A, C, sensors)``.

Shares nothing with :mod:`kfio.structure._fmo`, :mod:`kfio.sigma._sigma`,
:mod:`kfio.search._blind` or :mod:`kfio.design._regions`: the FMO blocks come from
floating-point eigenvectors (``numpy.linalg.eigvals`` and
``scipy.linalg.null_space``), the classes from numerical root-of-unity
tests, and the blind probability from the covered-set dynamic programme of
:class:`bruteforce.BlindDP`, which already runs one independent channel per
row group (per sensor).  Then per block

    rate_k = |alpha_k|^2 * (P(blind after (j+1) N0) / P(blind after j N0))^(1/N0),

Rohr, Marelli and Fu (2014), eq. (33), with ``P(blind)`` over the joint per-sensor arrivals
(docs/theory.md, "Beyond the seeds").  The critical probability of one
sensor is found by bisection on this rate (it decreases in every
``lambda_s``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from fractions import Fraction

import numpy as np
from scipy.linalg import null_space

from kfio.model._types import MarkovChannel
from kfio.structure._phases import PhaseBlock

from support.bruteforce import BlindDP, period_ratio

#: Largest root-of-unity order the numerical class test looks for.
MAX_ORDER = 24


def bernoulli(lam: float | Fraction) -> MarkovChannel:
    lam = Fraction(lam).limit_denominator(10**9) if isinstance(lam, float) else Fraction(lam)
    return MarkovChannel("bernoulli", 0, (lam,), {"arrival_probability": lam})


def _root_of_unity(r: complex) -> tuple[int, int] | None:
    """``(m, k)`` with ``r = exp(2 pi i k / m)``, ``m <= MAX_ORDER``, numerically."""
    if abs(abs(r) - 1) > 1e-9:
        return None
    t = (np.angle(r) / (2 * np.pi)) % 1.0
    for m in range(1, MAX_ORDER + 1):
        k = round(t * m)
        if abs(t * m - k) < 1e-8 * m:
            return m, k % m
    return None


def numeric_blocks(A: np.ndarray, C: np.ndarray, groups: Sequence[Sequence[int]]) -> list[tuple[float, PhaseBlock]]:
    """``(|alpha|^2, phase block)`` of every FMO class with ``|alpha| >= 1``, by floating point.

    Assumes the eigenvalues of modulus ``>= 1`` are semisimple (the random
    systems of the tests are diagonalizable); eigenspaces come from
    ``null_space(A - theta I)``, so repeated eigenvalues give several columns.
    """
    A = np.asarray(A, dtype=float)
    C = np.asarray(C, dtype=float)
    n = A.shape[0]
    distinct: list[complex] = []
    for w in np.linalg.eigvals(A):
        if all(abs(w - d) > 1e-7 * max(1.0, abs(w)) for d in distinct):
            distinct.append(complex(w))
    distinct = [d for d in distinct if abs(d) >= 1 - 1e-12]
    classes: list[list[tuple[complex, int, int]]] = []  # members (theta, m, k) relative to the head
    for d in sorted(distinct, key=lambda z: (-abs(z), np.angle(z))):
        for cls in classes:
            rel = _root_of_unity(d / cls[0][0])
            if rel is not None:
                cls.append((d, *rel))
                break
        else:
            classes.append([(d, 1, 0)])
    out = []
    for cls in classes:
        N0 = math.lcm(*(m for _, m, _ in cls))
        columns, exponents = [], []
        for theta, m, k in cls:
            basis = null_space(A - theta * np.eye(n), rcond=1e-9)
            for j in range(basis.shape[1]):
                v = C @ basis[:, j]
                columns.append(v / max(np.linalg.norm(v), 1e-300))
                exponents.append(k * (N0 // m) % N0)
        block = PhaseBlock(N0, tuple(exponents), np.column_stack(columns), tuple(tuple(g) for g in groups))
        out.append((abs(cls[0][0]) ** 2, block))
    return out


def block_rates(
    A: np.ndarray, C: np.ndarray, groups: Sequence[Sequence[int]], channels: Sequence[MarkovChannel]
) -> list[tuple[float, float]]:
    """``(|alpha|^2, |alpha|^2 sigma)`` per FMO block with ``|alpha| >= 1``, largest modulus first."""
    out = []
    for beta, block in numeric_blocks(A, C, groups):
        dp = BlindDP(block, channels)
        out.append((beta, beta * period_ratio(dp) ** (1.0 / dp.N0)))
    return out


def worst_rate(A: np.ndarray, C: np.ndarray, groups: Sequence[Sequence[int]], lambdas: Sequence[float]) -> float:
    """The largest block rate under independent Bernoulli sensors (0 if no block has ``|alpha| >= 1``)."""
    rates = block_rates(A, C, groups, [bernoulli(x) for x in lambdas])
    return max((r for _, r in rates), default=0.0)


def critical_probability(
    A: np.ndarray,
    C: np.ndarray,
    groups: Sequence[Sequence[int]],
    lambdas: Sequence[float],
    sensor: int,
    tol: float = 1e-7,
    edge: float = 1e-6,
) -> float | None:
    """``lambda_{s,c}`` by bisection on :func:`worst_rate`: ``0.0`` if stable at ``edge``, ``None`` if unstable at ``1 - edge``."""

    def rate(x: float) -> float:
        lam = list(lambdas)
        lam[sensor] = x
        return worst_rate(A, C, groups, lam)

    if rate(1 - edge) >= 1:
        return None
    if rate(edge) < 1:
        return 0.0
    lo, hi = edge, 1 - edge
    while hi - lo > tol:
        mid = (lo + hi) / 2
        if rate(mid) >= 1:
            lo = mid
        else:
            hi = mid
    return (lo + hi) / 2


# -- requests ------------------------------------------------------------------

#: Liu and Goldsmith (2004)'s two-packet systems (docs/theory.md), ``(A, [C_1, C_2])``; Q = 20 I and R = 2.5 I in the seed.
SEED000 = {
    # Section VI.A, Case 1: C_1 and C_2 square and invertible.
    "case1": ([[1.25, 0], [1, 1.1]], [[[1, 0], [0, 1]], [[1, 0], [1, 1]]]),
    # Section VI.A, Case 2: one unstable mode.
    "case2": ([[1.25, 0], [1, 0.9]], [[[1, 0]], [[0, 1]]]),
    # Section VI.B: two independent scalar systems.
    "diagonal": ([[2.5, 0], [0, 1.5]], [[[1, 0]], [[0, 1]]]),
    # Section VI.B, last example, and VI.C (lambda_1 = lambda_2 = 0.25 undecided by the bounds).
    "last": ([[1.25, 0], [1, 1.1]], [[[1, 0]], [[1, 1]]]),
}


def sensor_request(A, Cs, lambdas, noise: bool = True, channels=None, options=None):
    """A validated request: sensor ``s{i+1}`` carries the rows ``Cs[i]``; Q = 20 I, R = 2.5 I as in Liu and Goldsmith (2004)."""
    import json

    from kfio import load_request

    C = [row for rows in Cs for row in rows]
    sensors, k = [], 0
    for i, rows in enumerate(Cs):
        sensors.append({"name": f"s{i + 1}", "rows": list(range(k, k + len(rows)))})
        k += len(rows)
    n, p = len(A), len(C)
    system = {"A": A, "C": C, "sensors": sensors}
    if noise:
        system["Q"] = [[20 if i == j else 0 for j in range(n)] for i in range(n)]
        system["R"] = [["2.5" if i == j else 0 for j in range(p)] for i in range(p)]
    if channels is None:
        channels = {f"s{i + 1}": {"model": "bernoulli", "arrival_probability": str(x)} for i, x in enumerate(lambdas)}
    body = {"system": system, "channel": {"model": "per_sensor", "channels": channels}}
    if options is not None:
        body["options"] = options
    return load_request(json.dumps(body))
