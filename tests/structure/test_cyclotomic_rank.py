"""The FLINT rank oracle over Q(zeta_L) against SymPy's exact ranks (DomainMatrix over the same field).

Two levels: random matrices with rows ``c_ij zeta^(a_j n)`` and planted dependences,
ranked by :class:`CyclotomicRows` and by ``DomainMatrix.rank`` over
``QQ.algebraic_field(exp(2 pi i / L))``; and whole plants (rotations, repeated
eigenvalues, Jordan blocks, several outputs and sensors), whose blocks' FLINT
oracle must give the ranks of the SymPy route's oracle on random slot sets.
"""

from __future__ import annotations

import json
import random

import pytest
from flint import fmpq, fmpq_poly
from sympy import QQ, I, exp, pi
from sympy.polys.matrices import DomainMatrix

from kfio import load_request
from kfio.structure import _cyclotomic_rank, _fmo, fmo_blocks
from kfio.structure._cyclotomic_rank import CyclotomicRows, cyclotomic

from support.plants import block_diagonal, cyclotomic_companion


def _sympy_rank(L: int, rows: list[list[fmpq_poly]]) -> int:
    K = QQ.algebraic_field(exp(2 * pi * I / L))
    zeta = K.from_sympy(exp(2 * pi * I / L))

    def element(a: fmpq_poly):
        acc = K.zero
        for c in reversed(a.coeffs()):
            acc = acc * zeta + K.convert(QQ(int(c.p), int(c.q)))
        return acc

    entries = [[element(a) for a in row] for row in rows]
    return int(DomainMatrix(entries, (len(rows), len(rows[0])), K).rank())


def _random_oracle(rng: random.Random, L: int) -> CyclotomicRows:
    phi = cyclotomic(L)
    d = phi.degree()
    n_cols, p = rng.randint(1, 5), rng.randint(1, 3)
    exponents = [rng.choice([0, 1, L // 2, rng.randrange(L)]) for _ in range(n_cols)]
    if n_cols > 1 and rng.random() < 0.5:
        exponents[-1] = exponents[0]  # a repeated omega: dependent columns are common
    columns = []
    for j in range(n_cols):
        col = [
            fmpq_poly([fmpq(rng.randint(-3, 3), rng.choice([1, 2, 5])) for _ in range(rng.randint(0, d))]) % phi
            for _ in range(p)
        ]
        if j > 0 and exponents[j] == exponents[0] and rng.random() < 0.7:
            factor = fmpq_poly([rng.randint(-2, 2) or 1, rng.randint(-1, 1)])
            col = [(c * factor) % phi for c in columns[0]]  # a column proportional to the first
        columns.append(col)
    groups = [[i] for i in range(p)] if rng.random() < 0.5 else [list(range(p))]
    return CyclotomicRows(L, columns, exponents, groups, L)


def _rows(oracle: CyclotomicRows, slots: list[tuple[int, int]]) -> list[list[fmpq_poly]]:
    L, phi = oracle.L, oracle.phi
    out = []
    for n, g in slots:
        for i in oracle.groups[g]:
            row = []
            for j in range(oracle.n_columns):
                # the unscaled entry c_ij zeta^(a_j n): ratios times the column scale give the same rank
                e = oracle.exponents[j] * n % L
                row.append((oracle.ratios[j][i] * fmpq_poly([0] * e + [1])) % phi)
            out.append(row)
    return out


@pytest.mark.parametrize("seed", range(30))
def test_random_rows_have_sympys_rank(seed: int) -> None:
    rng = random.Random(seed)
    L = rng.choice([3, 4, 5, 7, 8, 9, 12, 15])
    oracle = _random_oracle(rng, L)
    slots_all = [(n, g) for n in range(L) for g in range(len(oracle.groups))]
    for _ in range(4):
        slots = rng.sample(slots_all, rng.randint(1, min(len(slots_all), oracle.n_columns + 2)))
        exact = _sympy_rank(L, _rows(oracle, slots))
        assert oracle(slots) == exact
        # a bound from below that is too low is raised by the primes' ranks, never trusted
        assert oracle._certified(sorted(set(oracle._row_keys(slots))), 0) == exact


def test_scaled_columns_keep_the_rank() -> None:
    # The oracle ranks c_ij / s_j; the unscaled rows must have the same rank over K.
    rng = random.Random(5)
    L = 7
    phi = cyclotomic(L)
    columns = [[fmpq_poly([rng.randint(-3, 3) for _ in range(6)]) % phi for _ in range(2)] for _ in range(3)]
    oracle = CyclotomicRows(L, columns, [1, 2, 1], [[0, 1]], L)
    for slots in ([(0, 0)], [(0, 0), (3, 0)], [(1, 0), (2, 0), (5, 0)]):
        rows = []
        for n, _ in slots:
            for i in range(2):
                rows.append(
                    [(columns[j][i] * fmpq_poly([0] * (oracle.exponents[j] * n % L) + [1])) % phi for j in range(3)]
                )
        assert oracle(slots) == _sympy_rank(L, rows)


def test_elimination_fallback_gives_the_same_ranks(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = random.Random(11)
    oracles = [_random_oracle(rng, rng.choice([5, 8, 9])) for _ in range(6)]
    picks = []
    for o in oracles:
        slots = [(n, g) for n in range(o.L) for g in range(len(o.groups))]
        picks.append([rng.sample(slots, rng.randint(1, min(len(slots), o.n_columns + 1))) for _ in range(3)])
    certified = [[o(s) for s in ps] for o, ps in zip(oracles, picks)]
    monkeypatch.setattr(_cyclotomic_rank, "MAX_PRIMES", 0)
    for o in oracles:
        o._cache.clear()
    assert [[o(s) for s in ps] for o, ps in zip(oracles, picks)] == certified
    assert any(r < o.n_columns for o, rs in zip(oracles, certified) for r in rs)


def _plant(A: list[list[int]], C: list[list[int]], sensors: bool) -> str:
    system: dict = {"A": A, "C": C}
    if sensors:
        system["sensors"] = [{"name": f"s{k}", "rows": [k]} for k in range(len(C))]
        channel = {
            "model": "per_sensor",
            "channels": {f"s{k}": {"model": "bernoulli", "arrival_probability": "1/2"} for k in range(len(C))},
        }
    else:
        channel = {"model": "bernoulli", "arrival_probability": "1/2"}
    return json.dumps({"system": system, "channel": channel})


def _plants() -> list[str]:
    rng = random.Random(3)
    rot = [[0, -2], [2, 0]]
    jordan = [[2, 1], [0, 2]]
    out = []
    for blocks in [
        (cyclotomic_companion(5), cyclotomic_companion(5)),  # repeated complex eigenvalues
        (cyclotomic_companion(3), cyclotomic_companion(4), [[2]]),
        (rot, rot, jordan),  # repeated, complex and a Jordan block of the same modulus
        (cyclotomic_companion(12), [[-2, 1], [0, -2]]),
        (cyclotomic_companion(9, alpha=3), [[3]]),
    ]:
        A = block_diagonal(*blocks)
        n = len(A)
        for p in (1, 2):
            C = [[rng.randint(-2, 2) for _ in range(n)] for _ in range(p)]
            C[0][0] = C[0][0] or 1
            out.append(_plant(A, C, sensors=p > 1))
    return out


@pytest.mark.parametrize("index", range(10))
def test_plant_blocks_agree_with_the_sympy_route(index: int, monkeypatch: pytest.MonkeyPatch) -> None:
    request = load_request(_plants()[index])
    fast = [b for b in fmo_blocks(request.system) if b.phase is not None]
    assert any(isinstance(b.phase.exact_rank, CyclotomicRows) for b in fast)
    monkeypatch.setattr(_fmo, "_cyclotomic_oracle", lambda *args: None)
    slow = [b for b in fmo_blocks(request.system) if b.phase is not None]
    rng = random.Random(index)
    for a, b in zip(fast, slow):
        assert a.eigenvalue_texts == b.eigenvalue_texts and a.phase.exponents == b.phase.exponents
        if not isinstance(a.phase.exact_rank, CyclotomicRows):
            continue
        N0, L = a.phase.base_period, a.phase.n_columns
        slots = [(n, g) for n in range(N0) for g in range(len(a.phase.row_groups))]
        for _ in range(12):
            pick = rng.sample(slots, rng.randint(1, min(len(slots), L + 1)))
            assert a.phase.exact_rank(pick) == b.phase.exact_rank(pick) == a.phase.numeric_rank(pick)
