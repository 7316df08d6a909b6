"""``positive_definite_exact`` against two independent exact routes: the pivoted rational LDL of the
validator (``is_psd``) and Sylvester's criterion with every leading minor computed in Fractions."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from kfio.model._request import is_psd
from kfio.riccati_bounds._certificate import _fmpq_mat, positive_definite_exact


def det(M: list[list[Fraction]]) -> Fraction:
    M = [row[:] for row in M]
    n, d = len(M), Fraction(1)
    for k in range(n):
        p = next((i for i in range(k, n) if M[i][k] != 0), None)
        if p is None:
            return Fraction(0)
        if p != k:
            M[k], M[p], d = M[p], M[k], -d
        d *= M[k][k]
        for i in range(k + 1, n):
            f = M[i][k] / M[k][k]
            M[i] = [a - f * b for a, b in zip(M[i], M[k])]
    return d


def sylvester(M: list[list[Fraction]]) -> bool:
    return all(det([row[:k] for row in M[:k]]) > 0 for k in range(1, len(M) + 1))


def cases(seed: int):
    rng = np.random.default_rng(seed)
    for _ in range(60):
        n = int(rng.integers(1, 7))
        B = [[Fraction(int(rng.integers(-9, 10)), int(rng.integers(1, 50))) for _ in range(n)] for _ in range(n)]
        r = int(rng.integers(1, n + 1))  # rank of B'B restricted: semidefinite when r < n
        G = [[sum(B[k][i] * B[k][j] for k in range(r)) for j in range(n)] for i in range(n)]
        shift = Fraction(int(rng.integers(-3, 4)), int(rng.integers(1, 1000)))  # indefinite, tiny margins too
        yield [[G[i][j] + (shift if i == j else 0) for j in range(n)] for i in range(n)]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_positive_definite_exact_agrees_with_two_exact_routes(seed) -> None:
    seen = set()
    for M in cases(seed):
        got = positive_definite_exact(_fmpq_mat(M))
        assert got == sylvester(M) == is_psd(tuple(map(tuple, M)), strict=True, exact=True)
        seen.add(got)
    assert seen == {True, False}


def test_positive_definite_exact_sees_a_margin_below_rounding() -> None:
    eps = Fraction(1, 2**80)
    M = [[Fraction(1), Fraction(1)], [Fraction(1), 1 + eps]]  # det = eps > 0: positive definite
    assert positive_definite_exact(_fmpq_mat(M))
    M[1][1] = 1 - eps
    assert not positive_definite_exact(_fmpq_mat(M))
    M[1][1] = Fraction(1)  # singular: semidefinite, not definite
    assert not positive_definite_exact(_fmpq_mat(M))
