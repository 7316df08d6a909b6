"""Exact comparisons of ``rate = |alpha|^2 sigma`` with 1 (Rohr, Marelli and Fu (2014), Theorem 1).

Three situations, all decided in exact arithmetic where the inputs allow:

* all channels Bernoulli: ``sigma^N = prod_g (1 - lambda_g)^{z_g}`` is
  rational, so ``rate^N = beta^N c`` is compared with 1 through
  :meth:`AlgebraicReal.compare_power`;
* Markov channels: ``sigma^N = rho(P_F)`` for the exact rational one-period
  transfer matrix ``P_F``; with ``beta`` rational, ``rho(P_F)`` is compared
  with ``beta^(-N)`` by counting the real roots of ``det(x I - P_F)`` above it
  (Sturm sequences), which is exact because ``rho`` is the largest real
  eigenvalue of a non-negative matrix (Perron-Frobenius);
* otherwise a 50-digit comparison with an explicit margin, reported as not
  certified.
"""

from __future__ import annotations

import functools
from fractions import Fraction
from typing import Any, Callable, Sequence

import mpmath
from sympy import QQ, CRootOf, Poly, oo
from sympy.polys.matrices import DomainMatrix

from .._verdicts import Verdict
from ..errors import NumericalFailure
from ..structure import MAX_PREC, START_PREC, AlgebraicReal, X, integer_coeffs, precision, root_balls, sign

#: Verdict names by the sign of ``rate - 1``: ``VERDICTS[sign + 1]``.
VERDICTS = (Verdict.STABLE, Verdict.BOUNDARY, Verdict.UNSTABLE)


def bernoulli_factor(exponents: Sequence[Fraction], lambdas: Sequence[Fraction], N: int) -> Fraction:
    """``sigma^N = prod_g (1 - lambda_g)^{z_g}`` with ``z_g = N * exponents[g]`` (Rohr, Marelli and Fu (2014), Corollary 2).

    Kept per exact ``(exponents, lambdas, N)`` (least recently used): a sweep
    asks for the same probabilities on many plants, and the block report and
    its tail ask twice per point.
    """
    return _bernoulli_factor(tuple(exponents), tuple(lambdas), N)


@functools.lru_cache(maxsize=4096)
def _bernoulli_factor(exponents: tuple[Fraction, ...], lambdas: tuple[Fraction, ...], N: int) -> Fraction:
    c = Fraction(1)
    for e, lam in zip(exponents, lambdas):
        z = e * N
        if z.denominator != 1:  # pragma: no cover - z_g counts phases
            raise NumericalFailure("non-integer blind count")
        c *= (1 - lam) ** int(z)
    return c


def compare_rate_bernoulli(
    beta: AlgebraicReal | None,
    beta_float: float,
    N: int,
    c: Fraction,
    enclosed: Callable[[int, Fraction], tuple[int, bool]] | None = None,
) -> tuple[int, bool]:
    """Sign of ``beta^N c - 1`` and whether it was decided exactly.

    ``enclosed(N, q)``, when given, is the sign of ``beta^N - q`` from a
    certified enclosure of ``beta`` (:meth:`kfio.structure.FmoBlock.compare_power`):
    it proves every strict inequality when ``beta`` has no exact form.
    """
    if c == 0:
        return -1, True
    if beta is None:
        if enclosed is not None:
            return enclosed(N, 1 / c)
        return _numeric_sign(mpmath.mpf(beta_float) ** N * (mpmath.mpf(c.numerator) / c.denominator) - 1), False
    return beta.compare_power(N, 1 / c), True


def rho_poly(P: Sequence[Sequence[Fraction]]) -> Poly:
    """Square-free part of ``det(x I - P)``: same distinct roots, each simple.

    ``count_roots`` and ``CRootOf`` count multiplicities; the square-free part
    makes "the largest real root" the last index and root counts distinct.
    """
    k = len(P)
    dm = DomainMatrix([[QQ(x.numerator, x.denominator) for x in row] for row in P], (k, k), QQ)
    return Poly(dm.charpoly(), X, domain=QQ).sqf_part()


def spectral_radius(P: Sequence[Sequence[Fraction]], digits: int = 30) -> mpmath.mpf:
    """Perron root of a non-negative rational matrix: its largest real eigenvalue (certified)."""
    chi = rho_poly(P)
    n_real = chi.count_roots()
    with mpmath.workdps(digits + 10):
        if n_real == 0:  # pragma: no cover - a non-negative matrix has a real Perron root
            return mpmath.mpf(0)
        return mpmath.mpf(str(CRootOf(chi, n_real - 1).evalf(digits)))


def compare_rate_markov(
    beta: AlgebraicReal | None,
    beta_float: float,
    N: int,
    P: Sequence[Sequence[Fraction]],
    beta_ball: Callable[[int], Any] | None = None,
) -> tuple[int, bool]:
    """Sign of ``beta^N rho(P) - 1`` and whether it was decided exactly.

    Rational ``beta``: exact (Sturm counts).  Otherwise certified enclosures
    of ``beta`` (exact minimal polynomial, or ``beta_ball(prec)``) and of
    the Perron root prove every strict inequality.
    """
    if beta is not None and beta.is_rational:
        assert beta.rational is not None
        if beta.rational == 0:
            return -1, True
        c = 1 / beta.rational**N
        chi = rho_poly(P)
        cq = QQ(c.numerator, c.denominator)
        above = chi.count_roots(cq, oo)
        at = chi.eval(cq) == 0
        if above - (1 if at else 0) > 0:
            return 1, True
        return (0 if at else -1), True
    ball = beta.ball if beta is not None else beta_ball
    if ball is not None:
        s = _enclosed_sign(ball, N, rho_poly(P))
        if s is not None:
            return s, True
    with mpmath.workdps(60):
        b = beta.approx(50) if beta is not None else mpmath.mpf(beta_float)
        return _numeric_sign(b**N * spectral_radius(P, 50) - 1), False


def _enclosed_sign(ball: Callable[[int], Any], N: int, chi: Poly) -> int | None:
    """Sign of ``beta^N rho - 1`` from enclosures (``rho`` the largest real root of ``chi``), if they prove it.

    Never proves an equality: ``None`` when the enclosures still contain 0
    at :data:`~kfio.structure._balls.MAX_PREC` bits.
    """
    coeffs = integer_coeffs(chi.all_coeffs())
    prec = START_PREC
    while prec <= MAX_PREC:
        roots, n_real = root_balls(coeffs, prec)
        if n_real == 0:  # pragma: no cover - a non-negative matrix has a real Perron root
            return None
        with precision(prec):
            s = sign(ball(prec) ** N * roots[n_real - 1].real - 1)
        if s:
            return s
        prec *= 4
    return None


def _numeric_sign(v: mpmath.mpf, margin: float = 1e-30) -> int:
    if abs(v) <= margin:
        return 0
    return 1 if v > 0 else -1
