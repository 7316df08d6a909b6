"""Exact eigenstructure of a rational matrix (docs/theory.md, step 1).

Everything stays over ``Q`` or a number field ``Q(theta) = Q[x]/(f)``:

* the characteristic polynomial of ``A`` over ``Q`` and its irreducible
  factors ``f`` (one Galois orbit of eigenvalues each, all sharing one Jordan
  structure);
* Jordan cell sizes from ranks over ``Q``:
  ``dim_Q ker f(A)^k = deg f * sum_cells min(k, size)``;
* a basis of the eigenspace ``ker(A - theta I)`` over ``Q(theta)``, computed
  once per factor (over ``Q`` alone for a simple root, by the adjugate);
  Galois conjugation carries it to every other root, so the eigenvectors of
  root ``i`` are the same polynomials evaluated at that root;
* certified root enclosures (flint ``complex_roots``, Arb balls) for every
  decision and edge conversion.

The characteristic polynomial, its factorization and the ranks are computed
by python-flint (FLINT/Arb); SymPy's number fields only serve repeated roots.

``sympy.Matrix.jordan_form`` is never used: it leaves ``Q`` and does not
scale (see ``bench/bench_verdict.py``).
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from functools import cached_property
from typing import Any, Callable, Sequence

import mpmath
from flint import fmpq, fmpq_mat, fmpq_poly
from sympy import QQ, CRootOf, Poly, symbols
from sympy.polys.matrices import DomainMatrix

from .._budget import Budget
from ..errors import NumericalFailure
from ..model import Matrix, to_domain
from ._adjugate import simple_eigenvector, to_fmpq_mat
from ._balls import START_PREC, IntCoeffs, integer_coeffs, ordered_roots, refine_root

X = symbols("x")
#: Decimal digits used for numerical edge conversions of algebraic numbers.
DIGITS = 60


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
    eigvec_coeffs:
        Basis of ``ker(A - theta I)`` over ``Q(theta)``: per basis vector, per
        component, the rational coefficients (lowest power of ``theta``
        first, ``deg f`` of them) of a polynomial in ``theta``.  Evaluated at
        any root of ``f`` it gives that root's eigenvectors (Galois
        conjugation).
    route:
        ``"adjugate"`` (simple root, :mod:`kfio.structure._adjugate`, over
        ``Q`` only) or ``"nullspace"`` (``DomainMatrix.nullspace`` over
        ``Q(theta)``, for repeated roots).
    """

    poly: Poly
    multiplicity: int
    jordan_sizes: tuple[int, ...]
    eigvec_coeffs: tuple[tuple[tuple[Fraction, ...], ...], ...]
    route: str = "adjugate"

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
    def int_coeffs(self) -> IntCoeffs:
        """``f`` scaled to a primitive integer polynomial, lowest degree first."""
        return integer_coeffs(self.poly.all_coeffs())

    @cached_property
    def _balls(self) -> tuple[tuple[Any, ...], int]:
        return ordered_roots(self.int_coeffs)

    @property
    def n_real(self) -> int:
        """Number of real roots (certified: their enclosures have an exactly zero imaginary part)."""
        return self._balls[1]

    def root_ball(self, i: int, prec: int = START_PREC) -> Any:
        """Certified enclosure (flint ``acb``) of root ``i`` at ``prec`` bits."""
        return refine_root(self.int_coeffs, i, prec)

    @cached_property
    def roots(self) -> tuple[mpmath.mpc, ...]:
        """Midpoints of the certified root enclosures, as mpmath numbers (at least :data:`DIGITS` digits).

        Real roots first in ascending order (exactly real), then the others
        by real part, imaginary part.  Labels only: the exact decisions use
        :meth:`root_ball`.
        """
        with mpmath.workdps(DIGITS + 20):
            return tuple(
                mpmath.mpc(_mpf(z.real.mid()), 0 if i < self.n_real else _mpf(z.imag.mid()))
                for i, z in enumerate(self._balls[0])
            )

    def is_real_root(self, i: int) -> bool:
        return i < self.n_real

    @cached_property
    def field(self) -> Any:
        """``QQ`` for a rational root, else ``QQ<theta>`` with generator ``CRootOf(f, 0)`` (built on demand)."""
        if self.degree == 1:
            return QQ
        return QQ.algebraic_field(CRootOf(self.poly, 0))

    @cached_property
    def eigvecs(self) -> DomainMatrix:
        """:attr:`eigvec_coeffs` as a :class:`DomainMatrix` over :attr:`field`, one row per vector."""
        K = self.field
        rows = []
        for vec in self.eigvec_coeffs:
            if K == QQ:
                rows.append([QQ(c[0].numerator, c[0].denominator) for c in vec])
            else:
                rows.append([K.new([QQ(x.numerator, x.denominator) for x in reversed(c)]) for c in vec])
        n = len(self.eigvec_coeffs[0]) if self.eigvec_coeffs else 0
        return DomainMatrix(rows, (len(rows), n), K)

    def coeffs_of(self, elem: Any) -> list[Fraction]:
        """Coefficients (lowest power first) of a field element as a polynomial in ``theta``."""
        if self.field == QQ:
            return [Fraction(int(elem.numerator), int(elem.denominator))]
        return [Fraction(int(c.numerator), int(c.denominator)) for c in reversed(elem.to_list())]

    def value_at(self, coeffs: Sequence[Fraction], i: int) -> mpmath.mpc:
        """A field element given by :meth:`coeffs_of`, evaluated at root ``i`` (Horner, 70 digits)."""
        theta = self.roots[i]
        with mpmath.workdps(DIGITS + 10):
            acc = mpmath.mpc(0)
            for c in reversed(coeffs):
                acc = acc * theta + mpmath.mpf(c.numerator) / c.denominator
            return acc

    def eigvec_values(self, i: int) -> list[list[mpmath.mpc]]:
        """Numerical eigenvectors of root ``i`` (basis of its eigenspace), rows."""
        return [[self.value_at(cs, i) for cs in vec] for vec in self.eigvec_coeffs]


def _mpf(x: Any) -> mpmath.mpf:
    """An exact flint ``arb`` midpoint as an mpmath number (no text, no rounding)."""
    man, exp = x.man_exp()
    return mpmath.mpf((int(man), int(exp)))


def _factor(cp: fmpq_poly) -> list[tuple[Poly, int]]:
    _, factors = cp.numer().factor()
    out = []
    for h, k in factors:
        c = [Fraction(int(x), 1) for x in reversed(h.coeffs())]
        lead = c[0]
        out.append((Poly([QQ(x.numerator, x.denominator) for x in (ci / lead for ci in c)], X, domain=QQ), int(k)))
    out.sort(
        key=lambda fk: (fk[0].degree(), [Fraction(int(c.numerator), int(c.denominator)) for c in fk[0].all_coeffs()])
    )
    return out


def _fmpq_poly(f: Poly) -> fmpq_poly:
    return fmpq_poly([fmpq(int(c.numerator), int(c.denominator)) for c in reversed(f.all_coeffs())])


def jordan_sizes(A: Any, f: Poly, multiplicity: int, tick: Callable[[], None] | None = None) -> tuple[int, ...]:
    """Jordan cell sizes of a root of ``f`` from ranks of ``f(A)^k`` over ``Q``.

    With ``d = deg f`` and ``c_k`` the number of cells of size ``>= k``,
    ``dim ker f(A)^k - dim ker f(A)^(k-1) = d * c_k``.  ``A`` is an
    ``fmpq_mat`` (ranks by flint) or a :class:`DomainMatrix`.
    """
    if multiplicity == 1:
        return (1,)
    Aq = A if isinstance(A, fmpq_mat) else to_fmpq_mat(A.to_list())
    n = Aq.nrows()
    d = int(f.degree())
    eye = fmpq_mat(n, n, [int(i == j) for i in range(n) for j in range(n)])
    B = Aq * 0
    for c in f.all_coeffs():
        B = B * Aq + eye * fmpq(int(c.numerator), int(c.denominator))
    Bk = B
    prev_null = 0
    at_least: list[int] = []
    for _ in range(multiplicity):
        if tick is not None:
            tick()
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


def _nullspace_coeffs(Ad: DomainMatrix, f: Poly) -> tuple[tuple[tuple[Fraction, ...], ...], ...]:
    """Eigenspace basis by ``DomainMatrix.nullspace`` over ``Q(theta)`` (the general route), as coefficients."""
    K, vecs = eigenspace(Ad, f)
    d = int(f.degree())
    out = []
    for row in vecs.to_list():
        vec = []
        for e in row:
            if K == QQ:
                cs = [Fraction(int(e.numerator), int(e.denominator))]
            else:
                cs = [Fraction(int(c.numerator), int(c.denominator)) for c in reversed(e.to_list())]
            vec.append(tuple(cs + [Fraction(0)] * (d - len(cs))))
        out.append(tuple(vec))
    return tuple(out)


def eigen_factors(A: Matrix, budget: Budget | None = None, route: str = "auto") -> list[EigenFactor]:
    """Exact eigenstructure of ``A``: one :class:`EigenFactor` per irreducible factor.

    Rohr, Marelli and Fu (2014), Section III, need the eigenvalues, their
    Jordan sizes and eigenvectors.  The characteristic polynomial, its
    factors over ``Q`` and the ranks giving Jordan sizes are computed by
    flint; eigenvectors of simple roots by the adjugate
    (:func:`kfio.structure._adjugate.simple_eigenvector`, over ``Q`` only),
    of repeated roots by a null space over ``Q(theta)``.

    Parameters
    ----------
    A:
        Rational square matrix.
    budget:
        Checked once per factor and per rank or matrix-vector sweep.
    route:
        ``"auto"``; ``"nullspace"`` forces the number-field route for every
        factor (the test oracle).

    Examples
    --------
    >>> from fractions import Fraction as F
    >>> [f.jordan_sizes for f in eigen_factors(((F(2), F(1)), (F(0), F(2))))]
    [(2,)]
    """

    def tick() -> None:
        if budget is not None:
            budget.tick("eigenstructure", 64)

    Aq = to_fmpq_mat(A)
    cp = Aq.charpoly()
    tick()
    factors = _factor(cp)
    Ad: DomainMatrix | None = None
    out = []
    for f, k in factors:
        tick()
        sizes = jordan_sizes(Aq, f, k, tick)
        if k == 1 and route == "auto":
            b = simple_eigenvector(Aq, cp, _fmpq_poly(f), tick)
            coeffs: tuple[tuple[tuple[Fraction, ...], ...], ...] = (tuple(tuple(r) for r in b),)
            how = "adjugate"
        else:
            if Ad is None:
                Ad = to_domain(A)
            coeffs = _nullspace_coeffs(Ad, f)
            how = "nullspace"
        if len(coeffs) != len(sizes):  # pragma: no cover - algebraic identity
            raise NumericalFailure("eigenspace dimension differs from the number of Jordan cells")
        out.append(EigenFactor(poly=f, multiplicity=k, jordan_sizes=sizes, eigvec_coeffs=coeffs, route=how))
    return out
