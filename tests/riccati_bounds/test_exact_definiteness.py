"""``positive_definite_exact`` against two independent exact routes: the pivoted rational LDL of the
validator (``is_psd``) and Sylvester's criterion with every leading minor computed in Fractions."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from kfio.model._request import is_psd
from kfio.riccati_bounds._certificate import (
    _fmpq_mat,
    positive_definite_by_congruence,
    positive_definite_exact,
    positive_definite_sylvester,
)


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


def ill_conditioned(seed: int):
    """Float ``Q diag(s) Q'`` (exactly rational) with condition up to 1e12, shifted by +-2^-k ``I`` across the edge."""
    rng = np.random.default_rng(seed)
    for _ in range(12):
        n = int(rng.integers(2, 10))
        Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
        s = np.logspace(0, -float(rng.uniform(2, 12)), n)
        M = Q @ np.diag(s) @ Q.T
        M = 0.5 * (M + M.T)
        lam = min(np.linalg.eigvalsh(M)[0], 1e-3)
        for shift in (0.0, -0.5 * lam, -2.0 * lam, Fraction(-1, 2**100)):
            Mq = [[Fraction(float(x)) for x in r] for r in M]
            for i in range(n):
                Mq[i][i] += Fraction(shift)
            yield Mq


@pytest.mark.parametrize("seed", [0, 1])
def test_congruence_test_never_claims_more_than_sylvester(seed) -> None:
    """The congruence test is sufficient only: whenever it says ``True``, two exact routes agree; and it does decide
    most of the definite ones, well-conditioned or not (else the fast route would be dead code)."""
    decided = definite = 0
    for M in list(cases(seed)) + list(ill_conditioned(seed)):
        num, _ = _fmpq_mat(M).numer_denom()
        truth = sylvester(M)
        assert positive_definite_sylvester(num) == truth
        assert positive_definite_exact(_fmpq_mat(M)) == truth
        fast = positive_definite_by_congruence(num)
        assert not fast or truth
        definite += truth
        decided += fast
    assert definite > 20 and decided >= 0.8 * definite


def test_congruence_test_proves_a_condition_number_of_1e10() -> None:
    """A float ``X`` like the certificates' near the threshold: one direction 1e10 times the others."""
    rng = np.random.default_rng(5)
    n = 30
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    X = Q @ np.diag(np.r_[1e10, rng.uniform(1, 2, n - 1)]) @ Q.T
    X = 0.5 * (X + X.T)
    num, _ = _fmpq_mat(X).numer_denom()
    assert positive_definite_by_congruence(num)
    assert positive_definite_sylvester(num)
