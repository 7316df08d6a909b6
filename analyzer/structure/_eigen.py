"""Exact eigenstructure of a rational matrix (MATH.md section 2, step 1).

Everything stays over ``Q`` or a number field ``Q(theta) = Q[x]/(f)``:

* the characteristic polynomial of ``A`` over ``Q`` and its irreducible
  factors ``f`` (one Galois orbit of eigenvalues each, all sharing one Jordan
  structure);
* Jordan cell sizes from ranks over ``Q``:
  ``dim_Q ker f(A)^k = deg f * sum_cells min(k, size)``;
* a basis of the eigenspace ``ker(A - theta I)`` over ``Q(theta)``, computed
  once per factor; Galois conjugation carries it to every other root, so the
  eigenvectors of root ``i`` are the same polynomials evaluated at that root;
* certified numerical roots (``CRootOf`` isolation) at high precision for the
  edge conversions.

``sympy.Matrix.jordan_form`` is never used: it leaves ``Q`` and does not
scale (see ``bench/bench_verdict.py``).
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from functools import cached_property
from typing import Any

import mpmath
from sympy import QQ, CRootOf, Poly, symbols
from sympy.polys.matrices import DomainMatrix

from ..errors import NumericalFailure
from ..model._types import Matrix, to_domain

X = symbols("x")
#: Decimal digits used for numerical edge conversions of algebraic numbers.
DIGITS = 60


def _poly_at_matrix(coeffs: list[Any], A: DomainMatrix) -> DomainMatrix:
    """``f(A)`` by Horner's rule over ``QQ`` (``coeffs`` highest degree first)."""
    n = A.shape[0]
    result = DomainMatrix.zeros((n, n), QQ)
    eye = DomainMatrix.eye(n, QQ)
    for c in coeffs:
        result = result * A + eye * c
    return result


@dataclass(frozen=True)
class EigenFactor:
    """One irreducible factor ``f`` of the characteristic polynomial.

    Attributes
    ----------
    poly:
        ``f``, monic and irreducible over ``Q``.
    multiplicity:
        Algebraic multiplicity of each root (``f**multiplicity`` divides the
        characteristic polynomial exactly).
    jordan_sizes:
        Sizes of the Jordan cells of each root, largest first.  Their count is
        the geometric multiplicity.
    field:
        ``QQ`` for a rational root, else ``QQ<theta>`` with generator
        ``CRootOf(f, 0)``.
    eigvecs:
        Basis of ``ker(A - theta I)`` over ``field``, one row per vector, as a
        :class:`DomainMatrix` (shape ``(g, n)``).
    """

    poly: Poly
    multiplicity: int
    jordan_sizes: tuple[int, ...]
    field: Any
    eigvecs: DomainMatrix

    @property
    def degree(self) -> int:
        return int(self.poly.degree())

    @property
    def is_rational(self) -> bool:
        return self.degree == 1

    @property
    def is_zero(self) -> bool:
        return self.degree == 1 and self.poly.TC() == 0

    @property
    def rational_root(self) -> Fraction:
        """The root of a degree-1 factor."""
        c = -self.poly.TC()
        return Fraction(int(c.numerator), int(c.denominator))

    @cached_property
    def roots(self) -> tuple[mpmath.mpc, ...]:
        """Numerical roots to :data:`DIGITS` digits (``mpmath.polyroots`` with its error bound).

        Ordered by real part, then imaginary part.  SymPy's complex root
        isolation is exact but can take minutes on symmetric quartics such as
        ``x^4 + 81/16``; the exact decisions never depend on this order.
        """
        coeffs = [Fraction(int(c.numerator), int(c.denominator)) for c in self.poly.all_coeffs()]
        with mpmath.workdps(DIGITS + 20):
            mp = [mpmath.mpf(c.numerator) / c.denominator for c in coeffs]
            if self.degree == 1:
                return (mpmath.mpc(-mp[1] / mp[0]),)
            for steps in (100, 400, 1600):
                roots, err = mpmath.polyroots(mp, maxsteps=steps, extraprec=4 * DIGITS, error=True)
                if err < mpmath.mpf(10) ** -(DIGITS + 5):
                    break
            else:  # pragma: no cover - Durand-Kerner converges on square-free input
                from ..errors import NumericalFailure

                raise NumericalFailure(f"roots of {self.poly.as_expr()} did not converge")
            out = [mpmath.mpc(r) for r in roots]
            for i, r in enumerate(out):
                if abs(r.imag) < mpmath.mpf(10) ** -(DIGITS - 5) * max(1, abs(r)):
                    out[i] = mpmath.mpc(r.real, 0)
            out.sort(key=lambda z: (float(z.real), float(z.imag)))
            return tuple(out)

    def is_real_root(self, i: int) -> bool:
        return self.roots[i].imag == 0

    def coeffs_of(self, elem: Any) -> list[Fraction]:
        """Coefficients (lowest power first) of a field element as a polynomial in ``theta``."""
        if self.field == QQ:
            return [Fraction(int(elem.numerator), int(elem.denominator))]
        return [Fraction(int(c.numerator), int(c.denominator)) for c in reversed(elem.to_list())]

    def value_at(self, coeffs: list[Fraction], i: int) -> mpmath.mpc:
        """A field element given by :meth:`coeffs_of`, evaluated at root ``i`` (Horner, 70 digits)."""
        theta = self.roots[i]
        with mpmath.workdps(DIGITS + 10):
            acc = mpmath.mpc(0)
            for c in reversed(coeffs):
                acc = acc * theta + mpmath.mpf(c.numerator) / c.denominator
            return acc

    def eigvec_values(self, i: int) -> list[list[mpmath.mpc]]:
        """Numerical eigenvectors of root ``i`` (basis of its eigenspace), rows."""
        return [[self.value_at(self.coeffs_of(e), i) for e in row] for row in self.eigvecs.to_list()]


def irreducible_factors(A: Matrix) -> tuple[list[tuple[Poly, int]], DomainMatrix]:
    """Irreducible monic factors of ``det(x I - A)`` over ``Q`` with multiplicities."""
    Ad = to_domain(A)
    cp = Poly(Ad.charpoly(), X, domain=QQ)
    _, factors = cp.factor_list()
    out = [(f.monic(), int(k)) for f, k in factors]
    out.sort(key=lambda fk: (fk[0].degree(), [str(c) for c in fk[0].all_coeffs()]))
    return out, Ad


def jordan_sizes(Ad: DomainMatrix, f: Poly, multiplicity: int) -> tuple[int, ...]:
    """Jordan cell sizes of a root of ``f`` from ranks of ``f(A)^k`` over ``Q``.

    With ``d = deg f`` and ``c_k`` the number of cells of size ``>= k``,
    ``dim ker f(A)^k - dim ker f(A)^(k-1) = d * c_k``.
    """
    n = Ad.shape[0]
    d = int(f.degree())
    B = _poly_at_matrix([QQ.convert(c) for c in f.all_coeffs()], Ad)
    Bk = B
    prev_null = 0
    at_least: list[int] = []
    for _ in range(multiplicity):
        null = n - Bk.rank()
        c = (null - prev_null) // d
        if c == 0:
            break
        at_least.append(c)
        prev_null = null
        if null == d * multiplicity:
            break
        Bk = Bk * B
    sizes: list[int] = []
    for k, c in enumerate(at_least, start=1):
        nxt = at_least[k] if k < len(at_least) else 0
        sizes.extend([k] * (c - nxt))
    sizes.sort(reverse=True)
    if sum(sizes) != multiplicity:  # pragma: no cover - algebraic identity
        raise NumericalFailure("Jordan sizes do not add up to the multiplicity")
    return tuple(sizes)


def eigenspace(Ad: DomainMatrix, f: Poly) -> tuple[Any, DomainMatrix]:
    """Basis of ``ker(A - theta I)`` over ``Q(theta)``, ``f(theta) = 0``."""
    n = Ad.shape[0]
    if f.degree() == 1:
        K = QQ
        theta = QQ.convert(-f.TC())
    else:
        K = QQ.algebraic_field(CRootOf(f, 0))
        theta = K.from_sympy(K.ext)
    AK = Ad.convert_to(K)
    M = AK - DomainMatrix.eye(n, K) * theta
    return K, M.nullspace()


def eigen_factors(A: Matrix) -> list[EigenFactor]:
    """Exact eigenstructure of ``A``: one :class:`EigenFactor` per irreducible factor.

    Examples
    --------
    >>> from fractions import Fraction as F
    >>> [f.jordan_sizes for f in eigen_factors(((F(2), F(1)), (F(0), F(2))))]
    [(2,)]
    """
    factors, Ad = irreducible_factors(A)
    out = []
    for f, k in factors:
        sizes = jordan_sizes(Ad, f, k)
        K, vecs = eigenspace(Ad, f)
        if vecs.shape[0] != len(sizes):  # pragma: no cover - algebraic identity
            raise NumericalFailure("eigenspace dimension differs from the number of Jordan cells")
        out.append(EigenFactor(poly=f, multiplicity=k, jordan_sizes=sizes, field=K, eigvecs=vecs))
    return out
