"""The exact per-sensor region against the brute-force blind probability.

Random small systems with two sensors, ``A = T D T^-1`` with ``T`` integer
unimodular and ``D`` block diagonal with eigenvalues of modulus 2 and 3/2
(real, rotations by quarter turns, repeated ones), so FMO classes of period
up to 4 with several Jordan chains and genuinely degenerate per-sensor blind
patterns.  The oracle (:mod:`bruteforce_sensors`) rebuilds the blocks from
floating-point eigenvectors and runs the covered-set DP over joint
per-sensor arrivals, sharing nothing with the analyzer.

Tolerances: the oracle's block rate converges (``2^20`` periods) far below
``1e-9``; its bisection of a critical probability stops at ``1e-7``.  We
allow ``1e-8`` relative on rates and ``1e-6`` on thresholds.
"""

from __future__ import annotations

import math
from fractions import Fraction as F

import numpy as np
import pytest
import sympy

from kfio import analyze
from kfio.design._regions import sensor_thresholds
from kfio.design._regions_constraints import block_rate
from kfio.model._types import MarkovChannel

from support.bruteforce_sensors import bernoulli, block_rates, critical_probability, sensor_request

SEED = 20240617
RATE_TOL = 1e-8
THRESHOLD_TOL = 1e-6

#: Diagonal building blocks ``D_i`` (rational entries): eigenvalues 2, -2, 3/2, +-2i, +-3/2 i, 1/2.
PARTS = [
    [[2]],
    [[-2]],
    [["3/2"]],
    [["1/2"]],
    [[0, -2], [2, 0]],
    [[0, "-3/2"], ["3/2", 0]],
]


def _block_diag(parts: list[list[list]]) -> sympy.Matrix:
    return sympy.diag(*[sympy.Matrix([[sympy.Rational(x) for x in row] for row in p]) for p in parts])


def random_system(i: int) -> tuple[list, list, list[float]]:
    """``(A, [C_1, C_2], lambdas)`` with exact rational ``A`` (as text) and small integer ``C_s``."""
    rng = np.random.default_rng([SEED, i])
    while True:
        parts = [PARTS[k] for k in rng.choice(len(PARTS), size=int(rng.integers(1, 4)))]
        D = _block_diag(parts)
        n = D.shape[0]
        if n <= 4 and any(abs(complex(e)) >= 1 for e in D.eigenvals()):
            break
    U = sympy.eye(n)
    for _ in range(2):
        E = sympy.eye(n)
        a, b = rng.choice(n, size=2, replace=False) if n > 1 else (0, 0)
        if a != b:
            E[int(a), int(b)] = int(rng.integers(-1, 2))
        U = U * E
    A = U * D * U.inv()
    rows = [int(r) for r in rng.integers(1, 3, size=2)]
    Cs = [[[int(x) for x in rng.integers(-1, 2, size=n)] for _ in range(r)] for r in rows]
    for C in Cs:
        if not any(any(row) for row in C):
            C[0][0] = 1
    lambdas = [float(x) for x in rng.choice([0.2, 0.35, 0.5, 0.65, 0.8, 0.9], size=2)]
    return [[str(x) for x in row] for row in A.tolist()], Cs, lambdas


def numeric(A: list, Cs: list) -> tuple[np.ndarray, np.ndarray, list[list[int]]]:
    C = np.array([row for rows in Cs for row in rows], dtype=float)
    groups, k = [], 0
    for rows in Cs:
        groups.append(list(range(k, k + len(rows))))
        k += len(rows)
    return np.array([[float(F(x)) for x in row] for row in A]), C, groups


def _sorted(rates: list[tuple[float, float]]) -> list[tuple[float, float]]:
    return sorted(rates, key=lambda br: (-round(br[0], 9), -br[1]))


@pytest.mark.parametrize("i", range(40))
def test_block_rates_match_bruteforce(i: int) -> None:
    A, Cs, lambdas = random_system(i)
    th = sensor_thresholds(sensor_request(A, Cs, lambdas, noise=False))
    mine = _sorted([(b.beta_float, block_rate(b, lambdas)) for b in th.blocks])
    oracle = _sorted(block_rates(*numeric(A, Cs), [bernoulli(x) for x in lambdas]))
    assert len(mine) == len(oracle)
    for (b1, r1), (b2, r2) in zip(mine, oracle):
        assert b1 == pytest.approx(b2, rel=1e-12)
        assert r1 == pytest.approx(r2, rel=RATE_TOL)
    assert th.certified


@pytest.mark.parametrize("i", range(12))
def test_thresholds_match_bruteforce(i: int) -> None:
    A, Cs, lambdas = random_system(i)
    th = sensor_thresholds(sensor_request(A, Cs, lambdas, noise=False))
    for s, t in enumerate(th.thresholds):
        oracle = critical_probability(*numeric(A, Cs), lambdas, sensor=s)
        if t.status == "none":
            assert oracle is None
        else:
            assert oracle is not None and abs(oracle - t.critical) < THRESHOLD_TOL, (s, t, oracle)


def _ge(p: str, q: str) -> dict:
    return {"model": "gilbert_elliott", "failure_rate": p, "recovery_rate": q}


@pytest.mark.parametrize("i", range(10))
def test_analyze_per_sensor_markov_matches_bruteforce(i: int) -> None:
    """``analyze`` with any channel per sensor: block rates against the DP."""
    A, Cs, _ = random_system(100 + i)
    rng = np.random.default_rng([SEED, 200 + i])
    specs = []
    for _ in range(2):
        p, q = (F(int(x), 20) for x in rng.integers(2, 19, size=2))
        specs.append((p, q) if rng.random() < 0.7 else None)
    lam = F(int(rng.integers(3, 18)), 20)
    channels, objs = {}, []
    for s, spec in enumerate(specs):
        if spec is None:
            channels[f"s{s + 1}"] = {"model": "bernoulli", "arrival_probability": str(lam)}
            objs.append(bernoulli(lam))
        else:
            p, q = spec
            channels[f"s{s + 1}"] = _ge(str(p), str(q))
            objs.append(MarkovChannel("gilbert_elliott", 1, (q, 1 - p)))
    rep = analyze(sensor_request(A, Cs, None, noise=False, channels=channels))
    mine = _sorted([(b.modulus**2, b.rate) for b in rep.blocks if b.rate is not None])
    oracle = _sorted(block_rates(*numeric(A, Cs), objs))
    assert len(mine) == len(oracle)
    assert all(b.basis == "extension" for b in rep.blocks)
    for (b1, r1), (b2, r2) in zip(mine, oracle):
        assert b1 == pytest.approx(b2, rel=1e-9)
        assert r1 == pytest.approx(r2, rel=RATE_TOL)


# Named degenerate two-sensor blocks: (A, [C_1, C_2]) and the exact rate^N per unit of (1 - lambda_1)^z1 (1 - lambda_2)^z2.
DEGENERATE = {
    # phase-0 rows [1 1] and [1 -1] are independent, but the (phase, sensor) pattern
    # {(0, s1), (1, s2)} sees only x1 + (-1)^t x2: N = 2, z = (1, 1).
    "swap": ([[2, 0], [0, -2]], [[[1, 1]], [[1, -1]]], [(1, 1)]),
    # both sensors see x1 + x2: each blind alone at alternate phases; the largest pattern
    # {(0, s1), (0, s2)} has z = (1, 1), the same as the swap.
    "same_row": ([[2, 0], [0, -2]], [[[1, 1]], [[1, 1]]], [(1, 1)]),
    # sensor 1 sees only x1 (blind to the -2 mode), sensor 2 sees x1 + x2: patterns {all s1} (z = (0, 2))
    # and {(0, s2)} U ... (z = (2, 1)).
    "one_blind": ([[2, 0], [0, -2]], [[[1, 0]], [[1, 1]]], [(0, 2), (2, 1)]),
    # quarter-turn rotation doubled with an eigenvalue 2: class {2, 2i, -2i}, N = 4.
    "rotation": ([[2, 0, 0], [0, 0, -2], [0, 2, 0]], [[[1, 1, 0]], [[0, 1, 1]]], None),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(DEGENERATE))
@pytest.mark.parametrize("lambdas", [(0.3, 0.6), (0.75, 0.2), (0.9, 0.9)])
def test_named_degenerate_blocks(name: str, lambdas: tuple[float, float]) -> None:
    A, Cs, zs = DEGENERATE[name]
    th = sensor_thresholds(sensor_request(A, Cs, list(lambdas), noise=False))
    [block] = th.blocks
    if zs is not None:
        assert sorted(p.misses for p in block.patterns) == sorted(zs)
    [(beta, oracle)] = block_rates(*numeric(A, Cs), [bernoulli(x) for x in lambdas])
    assert block_rate(block, list(lambdas)) == pytest.approx(oracle, rel=RATE_TOL)
    if zs is not None:
        closed = beta * max((1 - lambdas[0]) ** z1 * (1 - lambdas[1]) ** z2 for z1, z2 in zs) ** (1 / block.period)
        assert oracle == pytest.approx(closed, rel=RATE_TOL)
    for s, t in enumerate(th.thresholds):
        o = critical_probability(*numeric(A, Cs), list(lambdas), sensor=s)
        assert (o is None) if t.status == "none" else abs(o - t.critical) < THRESHOLD_TOL
    assert math.isfinite(oracle)


def _curved_systems(count: int = 6) -> list[int]:
    """Random systems whose boundary curve has at least two closed-form pieces (chosen by index, deterministically)."""
    from kfio.design._regions import exact_region_grid

    out = []
    for i in range(60):
        A, Cs, lambdas = random_system(i)
        if len(exact_region_grid(sensor_request(A, Cs, lambdas, noise=False), 2).curve.pieces) >= 2:
            out.append(i)
        if len(out) == count:
            break
    return out


@pytest.mark.parametrize("i", _curved_systems())
def test_boundary_curve_matches_bruteforce(i: int) -> None:
    """``h(lambda_1)`` is the oracle's critical ``lambda_2``; breakpoints are where adjacent pieces meet."""
    from kfio.design._regions import exact_region_grid

    A, Cs, lambdas = random_system(i)
    curve = exact_region_grid(sensor_request(A, Cs, lambdas, noise=False), 2).curve
    for lam1 in (0.1, 0.3, 0.5, 0.7, 0.9):
        h = curve.h(lam1)
        oracle = critical_probability(*numeric(A, Cs), [lam1, 0.5], sensor=1)
        assert (oracle is None) if h is None else abs(oracle - h) < THRESHOLD_TOL, (lam1, h, oracle)
    lam = sympy.Symbol("lambda_1")
    segs = curve.envelope.segments
    for left, right in zip(segs, segs[1:]):
        assert float(sympy.sympify(left.end_exact)) == pytest.approx(left.end, abs=1e-14)
        assert left.end_exact == right.start_exact
        values = []
        for seg in (left, right):
            if seg.piece is None:
                values.append(0.0)
            else:
                rhs = sympy.sympify(curve.pieces[seg.piece].formula.split("=", 1)[1])
                values.append(float(rhs.subs(lam, sympy.sympify(left.end_exact))))
        assert values[0] == pytest.approx(values[1], abs=1e-12)
