"""Certified root-of-unity tests for ratios of eigenvalues (FMO relations).

Rohr, Marelli and Fu (2014), Definition 3: ``theta_i ~ theta_j`` when
``theta_i / theta_j`` is a root of unity.  For roots ``theta_u`` of ``f`` and
``theta_v`` of ``g`` the ratio ``r = theta_v / theta_u`` is algebraic of
degree at most ``D = deg f * deg g``; if it is a primitive ``m``-th root of
unity then ``phi(m) <= D``, and ``phi(m) >= sqrt(m / 2)`` bounds
``m <= M = 2 D^2``.  Hence, with ``t = arg(r) / (2 pi)``:

* a ball for ``|r|^2`` that excludes 1 proves "no relation" (different
  moduli settle most pairs at once);
* two fractions with denominators ``<= M`` differ by at least ``1 / M^2``,
  so once the ball for ``t`` is narrower than that it holds at most one
  candidate ``k / m``; none proves "no relation" for every order ``m`` at
  once (each ``|r^m - 1|`` is then provably non-zero);
* a candidate is confirmed or refuted exactly: ``theta_u^m = theta_v^m``
  holds iff both are roots of the same irreducible factor of the power
  polynomials ``charpoly(C_f^m)``, ``charpoly(C_g^m)`` and their enclosures
  fall into the same isolating ball of that factor's roots.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from functools import lru_cache
from typing import Any, Callable

from flint import acb, arb, fmpq, fmpq_mat, fmpz_poly

from ..errors import NumericalFailure
from ._balls import MAX_PREC, START_PREC, IntCoeffs, precision, root_balls


def euler_phi(m: int) -> int:
    """Euler's totient."""
    result, k, p = m, m, 2
    while p * p <= k:
        if k % p == 0:
            while k % p == 0:
                k //= p
            result -= result // p
        p += 1
    if k > 1:
        result -= result // k
    return result


@dataclass(frozen=True)
class Root:
    """A root of an integer polynomial, with a way to enclose it at any precision."""

    coeffs: IntCoeffs
    ball: Callable[[int], acb]


@lru_cache(maxsize=256)
def _power_factors(coeffs: IntCoeffs, m: int) -> tuple[IntCoeffs, ...]:
    """Distinct irreducible factors of ``charpoly(C_f^m)``, whose roots are the ``theta^m``.

    They are the irreducible factors of the minimal polynomial of ``C_f^m``
    (a matrix's minimal and characteristic polynomials have the same roots),
    which FLINT factors much faster: for an irreducible ``f`` it is the
    minimal polynomial of ``theta^m``, of degree ``[Q(theta^m) : Q]``, where
    the characteristic polynomial is its power of degree ``deg f``
    (``(x - 1.1^210)^48`` at period 210).
    """
    d = len(coeffs) - 1
    lead = coeffs[-1]
    M = fmpq_mat(d, d)
    for i in range(1, d):
        M[i, i - 1] = 1
    for i in range(d):
        M[i, d - 1] = fmpq(-coeffs[i], lead)
    P = (M**m).minpoly()
    _, factors = P.numer().factor()
    return tuple(tuple(int(c) for c in h.coeffs()) for h, _ in factors)


def _which_factor(factors: tuple[IntCoeffs, ...], z: Callable[[int], acb]) -> IntCoeffs:
    """The one factor vanishing at the number enclosed by ``z(prec)`` (refined until unique)."""
    prec = START_PREC
    while prec <= MAX_PREC:
        with precision(prec):
            w = z(prec)
            hits = [h for h in factors if fmpz_poly(list(h))(w).contains(0)]
        if len(hits) == 1:
            return hits[0]
        if not hits:  # pragma: no cover - the number is a root of one factor
            raise NumericalFailure("a power of an eigenvalue is a root of no factor of its power polynomial")
        prec *= 2
    raise NumericalFailure("could not tell the irreducible factors of a power polynomial apart")


def _same_root(h: IntCoeffs, a: Callable[[int], acb], b: Callable[[int], acb]) -> bool:
    """Whether two roots of the irreducible ``h`` (given by enclosures) are equal."""
    prec = START_PREC
    while prec <= MAX_PREC:
        balls, _ = root_balls(h, prec)
        with precision(prec):
            za, zb = a(prec), b(prec)
            ia = [i for i, r in enumerate(balls) if r.overlaps(za)]
            ib = [i for i, r in enumerate(balls) if r.overlaps(zb)]
        if len(ia) == 1 and len(ib) == 1:
            return ia == ib
        prec *= 2
    raise NumericalFailure("could not match powers of eigenvalues to isolated roots")


def equal_powers(u: Root, v: Root, m: int) -> bool:
    """Exactly: ``theta_u^m == theta_v^m``."""

    def pu(prec: int) -> acb:
        return u.ball(prec) ** m

    def pv(prec: int) -> acb:
        return v.ball(prec) ** m

    hu = _which_factor(_power_factors(u.coeffs, m), pu)
    hv = _which_factor(_power_factors(v.coeffs, m), pv)
    if hu != hv:
        return False
    return _same_root(hu, pu, pv)


def _turns(r: acb) -> arb:
    """``arg(r) / (2 pi)`` modulo 1, as a ball that avoids the branch cut of ``arg``."""
    if r.real < 0:
        t = (-r).arg() / (2 * arb.pi()) + arb(1) / 2
    else:
        t = r.arg() / (2 * arb.pi())
    return t


def ratio_relation(u: Root, v: Root, degree_bound: int) -> tuple[tuple[int, int] | None, bool]:
    """Certified: ``(m, k)`` with ``theta_v / theta_u = exp(2 pi i k / m)``, or ``None``; and whether it was decided.

    ``degree_bound`` bounds the degree of the ratio over ``Q`` (``deg f *
    deg g``).  The second value is ``False`` only when :data:`MAX_PREC` bits
    did not suffice (never seen; the caller reports it).
    """
    M = 2 * degree_bound * degree_bound + 2
    need = arb(1) / (4 * M * M)
    prec = START_PREC
    while prec <= MAX_PREC:
        with precision(prec):
            a, b = u.ball(prec), v.ball(prec)
            r = b / a
            mod2 = (r * r.conjugate()).real
            if not mod2.contains(1):
                return None, True
            t = _turns(r)
            if t.rad() < need:
                mid = t.mid()
                man, exp = mid.man_exp()
                tq = Fraction(int(man)) * (Fraction(2) ** int(exp))
                cand = (tq - (tq.numerator // tq.denominator)).limit_denominator(M)
                if not t.contains(arb(fmpq(cand.numerator, cand.denominator))) and not t.contains(
                    arb(fmpq(cand.numerator, cand.denominator)) - 1
                ):
                    return None, True
                m, k = cand.denominator, cand.numerator % cand.denominator
                if euler_phi(m) > degree_bound:
                    return None, True
                if equal_powers(u, v, m):
                    return ((1, 0) if m == 1 else (m, k)), True
                return None, True
        prec *= 2
    return None, False


def _acb_value(x: Any) -> acb:  # pragma: no cover - convenience for debugging
    return acb(x)
