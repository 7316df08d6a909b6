"""The critical actuator arrival probability of the TCP-like control Riccati equation, exactly where it is known.

The control MARE ``S = A'SA + W - nu A'SB (B'SB + U)^-1 B'SA`` has a fixed point
iff some static ``L`` makes ``nu (A - BL) x (A - BL) + (1 - nu) A x A`` (Kronecker
products) Schur stable, i.e. iff the input packets arriving with probability
``nu`` can mean-square stabilize ``(A, B)`` (Schenato, Sinopoli, Franceschetti,
Poolla and Sastry 2007, Sec. V).  Its critical value ``nu_c`` is known in closed
form in three cases, all computed here over Q:

* one input (``B`` a column, scalar plants included):
  ``nu_c = 1 - 1/prod |theta_i|^2`` over the eigenvalues with ``|theta_i| > 1``
  (Elia 2005, the mean-square capacity of a single fading input);
* ``B`` square and invertible: ``nu_c = 1 - 1/rho(A)^2`` (any ``L = B^-1 (A - F)``
  places ``A - BL`` anywhere, so only the lost packets' ``(1 - nu) rho(A)^2`` counts);
* an unstable eigenvalue (``|theta| >= 1``) that ``B`` cannot reach: no ``nu``
  helps, since that mode evolves as ``theta`` whatever the input.

The product of the unstable moduli squared is, per irreducible factor ``f`` of
the characteristic polynomial whose roots all lie outside the unit circle,
``(f(0) / lead(f))^2`` exactly; roots inside and outside are told apart by the
Schur-Cohn test over Q (no floats).  A factor with roots on both sides (or on
the circle) gives an algebraic product, reported as a certified decimal only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Sequence

import flint

from ..model import Matrix, fraction_text

#: Working precision (bits) of the Arb enclosures of an algebraic product.
ARB_PRECISION = 256


@dataclass(frozen=True)
class ActuatorCritical:
    """The control MARE's critical actuator arrival probability ``nu_c``.

    Attributes
    ----------
    value:
        ``nu_c`` as a float (the midpoint of a certified enclosure when not rational), or ``None``.
    exact:
        Its exact text when rational, else ``None``.
    lower, upper:
        A certified bracket ``lower <= nu_c <= upper`` (equal ends when ``nu_c`` is known).
    is_exact:
        ``True`` when ``nu_c`` itself is known (not only a bracket).
    source:
        Which theorem or computation gave it.
    stabilizable:
        ``False`` when an eigenvalue with ``|theta| >= 1`` is not controllable: no ``nu`` stabilizes.
    """

    value: float | None
    exact: str | None
    lower: float | None
    upper: float | None
    is_exact: bool
    source: str
    stabilizable: bool = True
    exact_value: Fraction | None = None
    enclosure: tuple[Fraction, Fraction] | None = None
    lower_exact: Fraction | None = None


def qmat(m: Sequence[Sequence[Fraction]]) -> flint.fmpq_mat:
    """An exact matrix as FLINT's ``fmpq_mat``."""
    rows, cols = len(m), len(m[0]) if m else 0
    return flint.fmpq_mat(rows, cols, [flint.fmpq(x.numerator, x.denominator) for row in m for x in row])


def _coeffs(p: flint.fmpq_poly) -> list[Fraction]:
    """Coefficients of ``p``, lowest degree first, as fractions."""
    return [Fraction(int(c.p), int(c.q)) for c in p.coeffs()]


def schur_stable(coeffs: Sequence[Fraction]) -> bool:
    """Every root of ``p`` (real rational coefficients, lowest first) strictly inside the unit circle.

    The Schur-Cohn recursion: ``p`` of degree ``d`` is Schur stable iff
    ``|p_0| < |p_d|`` and ``(p_d p(z) - p_0 z^d p(1/z)) / z`` is; exact over Q.
    """
    c = list(coeffs)
    while len(c) > 1:
        a0, ad = c[0], c[-1]
        if abs(a0) >= abs(ad):
            return False
        rev = c[::-1]
        c = [ad * c[i] - a0 * rev[i] for i in range(1, len(c))]
    return True


def uncontrollable_polynomial(A: Matrix, B: Matrix) -> flint.fmpq_poly:
    """The characteristic polynomial of ``A`` on the quotient by the controllable subspace of ``(A, B)``.

    The Krylov matrix ``[B, AB, ..., A^(n-1) B]`` spans the controllable
    subspace ``V``; with a basis of its columns, ``A V = V A_c`` and the
    uncontrollable modes are the roots of ``charpoly(A) / charpoly(A_c)``.
    """
    Aq, Bq = qmat(A), qmat(B)
    n, m = Aq.nrows(), Bq.ncols()
    blocks = [Bq]
    for _ in range(n - 1):
        blocks.append(Aq * blocks[-1])
    K = flint.fmpq_mat(n, n * m, [blocks[j // m][i, j % m] for i in range(n) for j in range(n * m)])
    R, rank = K.rref()
    chi = Aq.charpoly()
    if rank == n:
        return flint.fmpq_poly([1])
    if rank == 0:
        return chi
    pivots, row = [], 0
    for j in range(n * m):
        if row < rank and R[row, j] != 0:
            pivots.append(j)
            row += 1
    V = flint.fmpq_mat(n, rank, [K[i, j] for i in range(n) for j in pivots])
    Vt = V.transpose()
    Ac = (Vt * V).inv() * Vt * Aq * V
    return chi // Ac.charpoly()


def reaches_every_unstable_mode(A: Matrix, B: Matrix) -> bool:
    """Whether every eigenvalue of ``A`` with ``|theta| >= 1`` is controllable from ``B`` (exact)."""
    return schur_stable(_coeffs(uncontrollable_polynomial(A, B)))


def _factors(A: Matrix) -> list[tuple[flint.fmpz_poly, int]]:
    chi = qmat(A).charpoly()
    _, factors = chi.numer().factor()
    return [(f, int(e)) for f, e in factors]


def _modulus_balls(f: flint.fmpz_poly) -> list[flint.arb]:
    """Certified enclosures of ``|theta|^2`` for the roots of ``f``, one per root (multiplicity counted)."""
    old = flint.ctx.prec
    flint.ctx.prec = ARB_PRECISION
    try:
        out = []
        roots: list[Any] = f.complex_roots()
        for z, mult in roots:
            out += [(z * z.conjugate()).real] * int(mult)
        return out
    finally:
        flint.ctx.prec = old


def unstable_modulus_product(A: Matrix) -> tuple[Fraction | None, flint.arb | None, list[tuple[int, ...]]]:
    """``prod |theta_i|^2`` over the eigenvalues with ``|theta_i| > 1``.

    Returns the product exactly when rational, its certified enclosure (Arb), and the
    integer coefficients (lowest first) of the irreducible factors with roots on both
    sides of the circle, whose contribution is algebraic.  ``(None, None, [])`` when a
    root cannot be told from the unit circle.
    """
    exact = Fraction(1)
    mixed: list[tuple[int, ...]] = []
    old = flint.ctx.prec
    flint.ctx.prec = ARB_PRECISION
    try:
        ball = flint.arb(1)
        for f, mult in _factors(A):
            c = [Fraction(int(x)) for x in f.coeffs()]
            if len(c) == 2:  # a rational root: on, inside or outside the circle, decided exactly
                r2 = (c[0] / c[1]) ** 2
                if r2 > 1:
                    exact *= r2**mult
                continue
            if schur_stable(c):
                continue
            if schur_stable(c[::-1]):  # every root outside: their product is f(0) / lead(f)
                exact *= (c[0] / c[-1]) ** (2 * mult)
                continue
            one = flint.arb(1)
            for b in _modulus_balls(f):
                if b > one:
                    ball *= b
                elif not b < one:
                    return None, None, []
            mixed += [tuple(int(x) for x in f.coeffs())] * mult
        ball *= flint.arb(flint.fmpq(exact.numerator, exact.denominator))
    finally:
        flint.ctx.prec = old
    return (exact if not mixed else None), ball, mixed


def _quadratic_text(rational: Fraction, quadratic: tuple[int, ...], near: float) -> str | None:
    """``nu_c = 1 - 1/(E x^2)`` exactly, ``x`` the outside root of ``c0 + c1 x + c2 x^2``, ``E`` rational.

    The roots squared solve ``(c2 z + c0)^2 - c1^2 z = 0`` (Graeffe); with
    ``z = 1/(E (1 - y))`` this is ``(c2 + c0 E (1 - y))^2 - c1^2 E (1 - y) = 0``, a quadratic in ``y``.
    """
    from ._algebraic import root_text

    c0, c1, c2 = (Fraction(x) for x in quadratic)
    E = rational
    # (c2 + c0 E - c0 E y)^2 - c1^2 E + c1^2 E y, coefficients in y, lowest first
    a0, a1 = c2 + c0 * E, -c0 * E
    poly = [a0 * a0 - c1 * c1 * E, 2 * a0 * a1 + c1 * c1 * E, a1 * a1]
    den = math.lcm(*(x.denominator for x in poly))
    ints = [int(x * den) for x in poly]
    return root_text(flint.fmpz_poly(ints), near)


def largest_modulus(A: Matrix) -> tuple[Fraction | None, float | None]:
    """``rho(A)^2`` exactly when the largest ``|theta|^2`` is rational and certified to be the largest."""
    best_ball: flint.arb | None = None
    best_exact: Fraction | None = None
    candidates = []
    for f, _ in _factors(A):
        c = [Fraction(int(x)) for x in f.coeffs()]
        balls = _modulus_balls(f)
        rational = None
        if len(c) == 2:
            rational = (c[0] / c[1]) ** 2
        elif len(c) == 3 and c[1] ** 2 < 4 * c[0] * c[2]:  # a complex pair: |theta|^2 = c0 / c2
            rational = c[0] / c[2]
        candidates.append((max(balls, key=lambda b: float(b.mid())), rational))
    for ball, rational in candidates:
        if best_ball is None or float(ball.mid()) > float(best_ball.mid()):
            best_ball, best_exact = ball, rational
    if best_ball is None:
        return Fraction(0), 0.0
    if best_exact is not None:
        q = flint.arb(flint.fmpq(best_exact.numerator, best_exact.denominator))
        if all(ball < q or (r is not None and r <= best_exact) for ball, r in candidates):
            return best_exact, float(best_exact)
    return None, float(best_ball.mid())


def _from_exact(x2: Fraction, source: str) -> ActuatorCritical:
    """``nu_c = 1 - 1/x2`` (``0`` when ``x2 <= 1``: a marginal or stable plant needs no minimum)."""
    x = max(Fraction(0), 1 - 1 / x2) if x2 else Fraction(0)
    return ActuatorCritical(float(x), fraction_text(x), float(x), float(x), True, source, exact_value=x)


def _algebraic(ball: flint.arb, mixed: list[tuple[int, ...]], A: Matrix, source: str) -> ActuatorCritical:
    """``nu_c = 1 - 1/M`` for an algebraic ``M`` (its certified enclosure): a decimal, a rational enclosure, exact text when quadratic."""
    old = flint.ctx.prec
    flint.ctx.prec = ARB_PRECISION
    try:
        nu = 1 - 1 / ball
        lo, hi = _fraction(nu.lower()), _fraction(nu.upper())
    finally:
        flint.ctx.prec = old
    value = float((lo + hi) / 2)
    text = None
    if len(mixed) == 1 and len(mixed[0]) == 3:  # one quadratic factor with a root on each side: nu_c is quadratic
        text = _quadratic_text(_rational_part(A, mixed[0]), mixed[0], value)
    return ActuatorCritical(
        value, text, float(lo), float(hi), True, source + " (algebraic: a certified enclosure)", enclosure=(lo, hi)
    )


def _fraction(x: flint.arb) -> Fraction:
    man, exp = x.mid().man_exp()
    return Fraction(int(man)) * Fraction(2) ** int(exp)


def _rational_part(A: Matrix, skip: tuple[int, ...]) -> Fraction:
    """The product of ``|theta|^2 > 1`` over every factor but ``skip`` (all of them rational contributions)."""
    exact = Fraction(1)
    for f, mult in _factors(A):
        c = [Fraction(int(x)) for x in f.coeffs()]
        if tuple(int(x) for x in f.coeffs()) == skip:
            continue
        if len(c) == 2:
            r2 = (c[0] / c[1]) ** 2
            exact *= r2**mult if r2 > 1 else 1
        elif not schur_stable(c):
            exact *= (c[0] / c[-1]) ** (2 * mult)
    return exact


def known_critical(A: Matrix, B: Matrix) -> ActuatorCritical | None:
    """``nu_c`` where a closed form holds (module docstring), else ``None`` (the caller brackets it)."""
    if not reaches_every_unstable_mode(A, B):
        return ActuatorCritical(
            None,
            None,
            None,
            None,
            True,
            "A has an eigenvalue with |theta| >= 1 that B cannot reach (an uncontrollable unstable mode): "
            "it evolves as theta whatever the input, so no actuator arrival probability stabilizes the loop",
            stabilizable=False,
        )
    n, m = len(A), len(B[0])
    if m == 1:
        source = "1 - 1/prod|unstable eigenvalues of A|^2, one input (Elia 2005)"
        prod, ball, mixed = unstable_modulus_product(A)
        if prod is not None:
            return _from_exact(prod, source)
        return None if ball is None else _algebraic(ball, mixed, A, source)
    if m == n and qmat(B).det() != 0:
        rho2, _ = largest_modulus(A)
        return None if rho2 is None else _from_exact(rho2, "1 - 1/rho(A)^2, B square and invertible")
    return None


__all__ = [
    "ActuatorCritical",
    "known_critical",
    "largest_modulus",
    "reaches_every_unstable_mode",
    "schur_stable",
    "uncontrollable_polynomial",
    "unstable_modulus_product",
]
