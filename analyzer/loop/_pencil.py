"""``det(P - x Q)`` for integer matrices, exactly, by multimodular arithmetic (FLINT ``nmod_mat``).

A link's parameter ``x`` enters the second-moment operator affinely,
``T(x) = T0 + x T1`` (:mod:`kfio.loop._critical`), so with ``D`` the least
common denominator of ``T0`` and ``T1`` the integer matrices ``P = D (I - T0)``
and ``Q = D T1`` give ``D^s det(I - T(x)) = det(P - x Q)``.

Structure: ``Q`` is zero outside a set ``J`` of ``r`` columns (the modes and
patterns the link touches), so for ``P`` invertible

    det(P - x Q) = det(P) det(I - x P^-1 Q) = det(P) det(I_r - x N),   N = (P^-1 Q)[J, J],

a polynomial of degree at most ``r``: one solve and one ``r x r``
characteristic polynomial per prime (``det(I_r - x N)`` is the reversed
characteristic polynomial of ``N``).  Primes below ``2^62`` where ``P`` is
singular are skipped.  The coefficients are rebuilt by the Chinese remainder
theorem until the product of the primes exceeds twice the bound

    sum_k |c_k| <= prod_i (||P_i|| + ||Q_i||)

(rows ``P_i``, ``Q_i``; the determinant is multilinear in the rows and each
term obeys Hadamard's inequality), so the result is exact, not probabilistic.
The rational route it replaces (``A0^-1 T1`` over Q, then its characteristic
polynomial) carries denominators of tens of thousands of bits; see
``bench/bench_loop.py`` for the measured ratio.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Iterator

import flint

from .._budget import Budget
from ..errors import NumericalFailure

#: Consecutive primes at which ``P`` may be singular before ``P`` is declared singular over Q.
MAX_SINGULAR_PRIMES = 8


def _primes_below(start: int) -> Iterator[int]:
    p = start
    while p > 2:
        p -= 1
        if flint.fmpz(p).is_prime():
            yield p


def integer_pencil(T0: flint.fmpq_mat, T1: flint.fmpq_mat) -> tuple[flint.fmpz_mat, flint.fmpz_mat]:
    """``(P, Q)`` with ``det(P - x Q) = D^s det(I - T0 - x T1)``, ``D`` the least common denominator."""
    s = T0.nrows()
    den = 1
    for M in (T0, T1):
        for i in range(s):
            for j in range(s):
                den = math.lcm(den, int(M[i, j].q))
    P = flint.fmpz_mat(s, s)
    Q = flint.fmpz_mat(s, s)
    for i in range(s):
        for j in range(s):
            a, b = T0[i, j], T1[i, j]
            P[i, j] = (den if i == j else 0) - int(a.p) * (den // int(a.q))
            Q[i, j] = int(b.p) * (den // int(b.q))
    return P, Q


def _coefficient_bound(P: flint.fmpz_mat, Q: flint.fmpz_mat) -> int:
    s = P.nrows()
    bound = 1
    for i in range(s):
        a = sum(int(P[i, j]) ** 2 for j in range(s))
        b = sum(int(Q[i, j]) ** 2 for j in range(s))
        bound *= math.isqrt(a) + math.isqrt(b) + 2
    return bound


def det_pencil(P: flint.fmpz_mat, Q: flint.fmpz_mat, budget: Budget | None = None) -> flint.fmpz_poly | None:
    """``det(P - x Q)`` exactly (module docstring); ``None`` when ``P`` is singular over Q.

    ``budget`` is checked at every prime (:class:`kfio.errors.BudgetExceeded`).
    """
    s = P.nrows()
    cols = [j for j in range(s) if any(Q[i, j] != 0 for i in range(s))]
    r = len(cols)
    QJ = flint.fmpz_mat(s, r, [Q[i, j] for i in range(s) for j in cols])
    need = 2 * _coefficient_bound(P, Q) + 1
    modulus = 1
    coeffs: list[int] = []
    singular = 0
    for p in _primes_below(1 << 62):
        if budget is not None:
            budget.tick("critical value: multimodular determinant")
        Pp = flint.nmod_mat(P, p)
        try:
            M = Pp.solve(flint.nmod_mat(QJ, p)) if r else None
        except ZeroDivisionError:
            singular += 1
            if singular == MAX_SINGULAR_PRIMES and P.rank() < s:
                return None
            continue
        det = int(Pp.det())
        if det == 0:
            if r:
                # cannot happen: nmod_mat.solve raises ZeroDivisionError for a matrix singular mod p, so
                # a solve that returned proves det(P) != 0 mod p (tests/loop/test_loop_degenerate.py)
                _fail()
            # r = 0 (the link does not enter the operator): no solve ran, so this is the singularity test
            singular += 1
            if singular == MAX_SINGULAR_PRIMES and P.rank() < s:
                return None
            continue
        if M is not None:
            N = flint.nmod_mat(r, r, [int(M[i, k]) for i in cols for k in range(r)], p)
            cp = [int(c) for c in N.charpoly().coeffs()]
            cp += [0] * (r + 1 - len(cp))
            residues = [(det * c) % p for c in reversed(cp)]  # det(P) x^r chi_N(1/x)
        else:
            residues = [det]
        if not coeffs:
            coeffs = residues
        else:
            inv = pow(modulus, -1, p)
            coeffs = [c + modulus * (((v - c) * inv) % p) for c, v in zip(coeffs, residues)]
        modulus *= p
        if modulus > need:
            break
    half = modulus // 2
    return flint.fmpz_poly([c - modulus if c > half else c for c in coeffs])


def _fail() -> None:
    raise NumericalFailure("the multimodular determinant met a prime where its own invariants failed")


def det_polynomial_of(T0: flint.fmpq_mat, T1: flint.fmpq_mat, budget: Budget | None = None) -> flint.fmpq_poly | None:
    """``det(I - T0 - x T1)`` up to a positive constant; shifts ``x`` when ``I - T0`` is singular."""
    for base in (Fraction(0), Fraction(1, 2), Fraction(1, 3), Fraction(2, 3), Fraction(1, 5), Fraction(4, 5)):
        b = flint.fmpq(base.numerator, base.denominator)
        P, Q = integer_pencil(T0 + b * T1, T1)  # det(I - T(base + y)) in y
        poly = det_pencil(P, Q, budget)
        if poly is None:
            continue
        return flint.fmpq_poly(poly)(flint.fmpq_poly([-b, 1]))  # y = x - base
    return None


__all__ = ["det_pencil", "det_polynomial_of", "integer_pencil"]
