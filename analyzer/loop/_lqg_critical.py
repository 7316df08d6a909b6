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


def unstable_modulus_product(A: Matrix) -> tuple[Fraction | None, float | None]:
    """``prod |theta_i|^2`` over the eigenvalues with ``|theta_i| > 1``: exact when rational, and its float.

    ``(None, None)`` when a root cannot be told from the unit circle; ``(None, x)``
    when the product is algebraic (a factor with roots on both sides of the circle).
    """
    exact: Fraction | None = Fraction(1)
    approx = 1.0
    for f, mult in _factors(A):
        c = [Fraction(int(x)) for x in f.coeffs()]
        if len(c) == 2:  # a rational root: on, inside or outside the circle, decided exactly
            r2 = (c[0] / c[1]) ** 2
            if r2 > 1:
                approx *= float(r2) ** mult
                exact = None if exact is None else exact * r2**mult
            continue
        if schur_stable(c):
            continue
        if schur_stable(c[::-1]) and c[0] != 0:  # every root outside: their product is f(0) / lead(f)
            part = (c[0] / c[-1]) ** (2 * mult)
            approx *= float(part)
            if exact is not None:
                exact *= part
            continue
        exact = None
        one = flint.arb(1)
        prod = flint.arb(1)
        for b in _modulus_balls(f):
            if b > one:
                prod *= b
            elif not b < one:
                return None, None
        approx *= float(prod.mid()) ** mult
    return exact, approx


def _largest_modulus(A: Matrix) -> tuple[Fraction | None, float | None]:
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
        prod, _ = unstable_modulus_product(A)
        return (
            None
            if prod is None
            else _from_exact(prod, "1 - 1/prod|unstable eigenvalues of A|^2, one input (Elia 2005)")
        )
    if m == n and qmat(B).det() != 0:
        rho2, _ = _largest_modulus(A)
        return None if rho2 is None else _from_exact(rho2, "1 - 1/rho(A)^2, B square and invertible")
    return None


__all__ = [
    "ActuatorCritical",
    "known_critical",
    "reaches_every_unstable_mode",
    "schur_stable",
    "uncontrollable_polynomial",
    "unstable_modulus_product",
]
