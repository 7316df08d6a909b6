"""``is_psd`` decides by size, not by the clock.

It gave up after 10 s of wall-clock time, so the same request could be
accepted or refused depending on the machine's load.  The exact route is now
bounded by Hadamard's bound of the integer-scaled matrix; here it is checked
against brute force (every principal minor, in Fractions) on random
near-singular matrices, and its refusal is checked to depend on the matrix
only.
"""

from __future__ import annotations

import itertools
import json
import random
from fractions import Fraction as F

import pytest

from kfio import load_request
from kfio.errors import LimitExceeded
from kfio.model import _request
from kfio.model._request import MAX_EXACT_PSD_BITS, hadamard_bits, is_psd


def _det(M: list[list[F]]) -> F:
    """Determinant by fraction Gaussian elimination (independent of the code under test)."""
    M = [row[:] for row in M]
    n, det = len(M), F(1)
    for c in range(n):
        piv = next((r for r in range(c, n) if M[r][c] != 0), None)
        if piv is None:
            return F(0)
        if piv != c:
            M[c], M[piv] = M[piv], M[c]
            det = -det
        det *= M[c][c]
        for r in range(c + 1, n):
            f = M[r][c] / M[c][c]
            M[r] = [a - f * b for a, b in zip(M[r], M[c])]
    return det


def _brute_psd(M, strict: bool) -> bool:
    """PSD iff every principal minor is >= 0; PD iff the leading ones are > 0 (Sylvester)."""
    n = len(M)
    if strict:
        return all(_det([row[:k] for row in M[:k]]) > 0 for k in range(1, n + 1))
    return all(
        _det([[M[i][j] for j in S] for i in S]) >= 0
        for k in range(1, n + 1)
        for S in itertools.combinations(range(n), k)
    )


def _near_singular(rng: random.Random, n: int) -> tuple[tuple[F, ...], ...]:
    """``B B^T`` with ``B`` of rank < n (PSD, singular), sometimes nudged to indefinite or to definite."""
    r = rng.randint(1, n - 1)
    B = [[F(rng.randint(-9, 9), rng.randint(1, 9)) for _ in range(r)] for _ in range(n)]
    M = [[sum(B[i][k] * B[j][k] for k in range(r)) for j in range(n)] for i in range(n)]
    nudge = rng.choice((0, F(-1, 10**12), F(1, 10**12)))
    i = rng.randrange(n)
    M[i][i] += nudge
    return tuple(tuple(row) for row in M)


@pytest.mark.parametrize("seed", range(40))
def test_exact_route_agrees_with_principal_minors(seed: int) -> None:
    rng = random.Random(seed)
    M = _near_singular(rng, rng.randint(2, 5))
    for strict in (False, True):
        expected = _brute_psd(M, strict)
        assert is_psd(M, strict, exact=True) == expected  # the exact route alone
        assert is_psd(M, strict) == expected  # filter, then the exact route


def _coprime_denominators(n: int) -> tuple[tuple[F, ...], ...]:
    """``v v^T`` with ``v_i = 1 / p_i`` for distinct 40-digit primes: singular, huge scaled entries."""
    import sympy

    primes = []
    p = 10**40
    while len(primes) < n:
        p = sympy.nextprime(p)
        primes.append(p)
    v = [F(1, q) for q in primes]
    return tuple(tuple(a * b for b in v) for a in v)


def test_refusal_depends_on_the_matrix_only() -> None:
    M = _coprime_denominators(12)
    assert hadamard_bits(M) > MAX_EXACT_PSD_BITS
    for _ in range(2):  # same answer every time, whatever the load
        with pytest.raises(LimitExceeded, match=r"^/system/Q: the matrix is too close to singular .* bits"):
            is_psd(M, strict=False, where="/system/Q")
    assert is_psd(M, strict=False, exact=True)  # the exact route itself is right, only bounded


def test_request_with_such_a_q_is_refused_with_the_field(monkeypatch: pytest.MonkeyPatch) -> None:
    M = _coprime_denominators(6)
    body = {
        "system": {
            "A": [[0] * 6 for _ in range(6)],
            "C": [[1] * 6],
            "Q": [[f"{x.numerator}/{x.denominator}" for x in row] for row in M],
        },
        "channel": {"model": "bernoulli", "arrival_probability": 0.5},
    }
    monkeypatch.setattr(_request, "MAX_EXACT_PSD_BITS", hadamard_bits(M) - 1)
    with pytest.raises(LimitExceeded, match="^/system/Q: "):
        load_request(json.dumps(body))
    monkeypatch.setattr(_request, "MAX_EXACT_PSD_BITS", hadamard_bits(M))
    assert load_request(json.dumps(body)).system.Q is not None


def test_the_clock_is_not_consulted(monkeypatch: pytest.MonkeyPatch) -> None:
    import time

    def no_clock() -> float:
        raise AssertionError("is_psd read the clock")

    monkeypatch.setattr(time, "monotonic", no_clock)
    monkeypatch.setattr(time, "time", no_clock)
    M = _near_singular(random.Random(7), 5)
    assert is_psd(M, strict=False) == _brute_psd(M, strict=False)
