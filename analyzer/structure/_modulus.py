"""``beta = |theta|^2`` of an eigenvalue as an exact real algebraic number.

Rohr, Marelli and Fu (2014), Theorem 1 compares ``|alpha_k|^2 sigma_k`` with
1, so ``beta`` is needed exactly where a comparison is tight.  For a root
``theta`` of the irreducible ``f`` (degree ``d``, companion matrix ``C_f``):

* rational ``theta``: ``theta^2``;
* real ``theta``: a root of the Graeffe transform ``g(x^2) = (-1)^d f(x) f(-x)``
  (roots ``theta_i^2``; the same polynomial as ``charpoly(C_f^2)``, from one
  polynomial product instead of a ``d x d`` characteristic polynomial);
* non-real ``theta``: ``theta * conj(theta)`` is a root of
  ``charpoly(Lambda^2 C_f)``, the second exterior power, whose eigenvalues are
  the ``theta_i theta_j`` with ``i < j`` (degree ``d (d - 1) / 2``, against
  ``d^2`` for the Kronecker square).

The minimal polynomial is the irreducible factor that vanishes on the
certified enclosure of ``beta``, and the root is the one real root of that
factor whose isolating ball meets the enclosure.  Factorizations are done
once per factor ``f``, not once per root.  The Graeffe transform needs none:
``g`` is the characteristic polynomial of ``theta^2`` over ``Q(theta)``,
i.e. the minimal polynomial of ``theta^2`` raised to the degree
``[Q(theta) : Q(theta^2)]``, which is 1 or 2; so ``g`` is irreducible or the
square of an irreducible polynomial.
"""

from __future__ import annotations

from fractions import Fraction
from functools import lru_cache
from itertools import combinations

from flint import arb, fmpq, fmpz_mat, fmpz_poly
from flint.utils.flint_exceptions import DomainError
from sympy import QQ, Poly

from ._algebraic import AlgebraicReal
from ._balls import MAX_PREC, START_PREC, IntCoeffs, integer_coeffs, precision, root_balls
from ._eigen import EigenFactor, X

#: Largest ``deg f`` for which ``|theta|^2`` of a non-real root is made exact
#: (``Lambda^2`` has dimension 45 at 10).
MAX_MODULUS_DEGREE = 10


def _companion(coeffs: IntCoeffs) -> fmpz_mat:
    """Integer companion matrix of ``lead^(d) f(x / lead)`` scaled back: exact for monic ``f``."""
    d = len(coeffs) - 1
    C = fmpz_mat(d, d)
    for i in range(1, d):
        C[i, i - 1] = 1
    for i in range(d):
        C[i, d - 1] = -coeffs[i]
    return C


@lru_cache(maxsize=256)
def _square_factors(coeffs: IntCoeffs) -> tuple[IntCoeffs, ...]:
    """Irreducible factors of ``charpoly(Lambda^2 C_f)``, whose roots include every ``|theta|^2`` of a non-real root of monic ``f``."""
    C = _companion(coeffs)
    d = C.nrows()
    pairs = list(combinations(range(d), 2))
    M = fmpz_mat(len(pairs), len(pairs))
    for a, (i, j) in enumerate(pairs):
        for b, (k, m) in enumerate(pairs):
            v = C[i, k] * C[j, m] - C[i, m] * C[j, k]
            if v:
                M[a, b] = v
    P = M.charpoly()
    _, factors = P.factor()
    return tuple(tuple(int(c) for c in h.coeffs()) for h, _ in factors)


@lru_cache(maxsize=256)
def _graeffe_factors(coeffs: IntCoeffs) -> tuple[IntCoeffs, ...]:
    """The irreducible factor over ``Q`` of the polynomial with roots ``theta_i^2`` (``f`` irreducible, any leading coefficient).

    ``f(x) = e(x^2) + x o(x^2)`` gives ``f(x) f(-x) = e(x^2)^2 - x^2 o(x^2)^2``, so
    ``g(y) = e(y)^2 - y o(y)^2`` has the roots ``theta_i^2`` (Graeffe's
    root-squaring step).  ``g`` is the minimal polynomial of ``theta^2`` to
    the power ``[Q(theta) : Q(theta^2)] <= 2`` (see the module docstring), so
    its square root, when it has one, is that minimal polynomial, else ``g`` is.
    """
    F = fmpz_poly(list(coeffs))
    d = len(coeffs) - 1
    even = fmpz_poly([F[i] for i in range(0, d + 1, 2)])
    odd = fmpz_poly([F[i] for i in range(1, d + 1, 2)])
    g = even * even - fmpz_poly([0, 1]) * odd * odd
    try:
        g = g.sqrt()
    except DomainError:
        pass
    return (integer_coeffs([int(c) for c in reversed(g.coeffs())]),)


def _monic_coeffs(f: EigenFactor) -> IntCoeffs | None:
    """Integer coefficients of ``f`` if it is monic over ``Z`` (its companion matrix is integral)."""
    c = f.int_coeffs
    return c if c[-1] == 1 else None


def modulus_squared(f: EigenFactor, index: int) -> AlgebraicReal | None:
    """``|theta|^2`` exactly for root ``index`` of ``f``, or ``None`` beyond :data:`MAX_MODULUS_DEGREE`.

    Non-monic integer ``f`` is first made monic by the substitution
    ``theta = y / a`` (``a`` the leading coefficient): ``|theta|^2 = |y|^2 / a^2``.
    """
    if f.is_rational:
        return AlgebraicReal.of_rational(f.rational_root**2)
    real = f.is_real_root(index)
    if not real and f.degree > MAX_MODULUS_DEGREE:
        return _reciprocal_modulus(f, index)
    c = f.int_coeffs
    if real:  # the roots of the Graeffe factor are the theta_i^2 themselves: no change of variable
        a = 1
        factors = _graeffe_factors(c)
    else:
        a = c[-1]
        d = len(c) - 1
        monic = tuple(c[i] * a ** (d - 1 - i) for i in range(d)) + (1,)  # y = a theta
        factors = _square_factors(monic)

    def beta_ball(prec: int) -> arb:
        z = f.root_ball(index, prec) * a
        beta: arb = (z * z.conjugate()).real
        return beta

    prec = START_PREC
    while prec <= MAX_PREC:
        with precision(prec):
            b = beta_ball(prec)
            hits = [h for h in factors if fmpz_poly(list(h))(b).contains(0)]
        if len(hits) == 1:
            break
        prec *= 2
    else:
        return None
    h = hits[0]
    scale = Fraction(1, a * a)
    if len(h) == 2:
        return AlgebraicReal.of_rational(Fraction(-h[0], h[1]) * scale)
    # the root of h(y) at y = a^2 beta; beta itself is a root of h(a^2 x)
    hx = tuple(h[i] * (a * a) ** i for i in range(len(h)))
    while prec <= MAX_PREC:
        balls, n_real = root_balls(hx, prec)
        with precision(prec):
            b = beta_ball(prec) / (a * a)
            idx = [i for i in range(n_real) if balls[i].real.overlaps(b)]
        if len(idx) == 1:
            lead = hx[-1]
            poly = Poly([QQ(x, lead) for x in reversed(hx)], X, domain=QQ)
            return AlgebraicReal(minpoly=poly, index=idx[0])
        prec *= 2
    return None


def _reciprocal_modulus(f: EigenFactor, index: int) -> AlgebraicReal | None:
    """``|theta|^2 = q`` for a rational ``q``, proved when ``f`` is ``q``-reciprocal, else ``None``.

    If ``x^d f(q / x)`` is proportional to ``f`` then ``q / theta`` is a root
    of ``f``; it is ``conj(theta)`` (so ``|theta|^2 = q``) iff the two lie in
    the same isolating ball.  This covers ``alpha`` times a cyclotomic
    polynomial (roots ``alpha zeta``) at any degree.
    """
    with precision(START_PREC):
        z = f.root_ball(index)
        b = (z * z.conjugate()).real
        man, exp = b.mid().man_exp()
    q = (Fraction(int(man)) * Fraction(2) ** int(exp)).limit_denominator(1 << 40)
    if q <= 0:
        return None
    c = [Fraction(x) for x in f.int_coeffs]
    d = len(c) - 1
    rec = [c[d - i] * q ** (d - i) for i in range(d + 1)]  # coefficients of x^d f(q / x)
    ratio = rec[d] / c[d]
    if ratio == 0 or any(rec[i] != ratio * c[i] for i in range(d + 1)):
        return None
    balls = [f.root_ball(i) for i in range(f.degree)]
    with precision(START_PREC):
        conj = z.conjugate()
        image = arb(fmpq(q.numerator, q.denominator)) / z
        a = [i for i, r in enumerate(balls) if r.overlaps(conj)]
        bb = [i for i, r in enumerate(balls) if r.overlaps(image)]
    if len(a) == 1 and a == bb:
        return AlgebraicReal.of_rational(q)
    return None
