"""FMO blocks (seed 001, Definitions 3-5) and their phase form.

Eigenvalues ``theta_i ~ theta_j`` when ``theta_i / theta_j`` is a root of
unity (they have a *finite multiplicative order* up to a constant).  A class
has one modulus ``|alpha_k|``; zero eigenvalues form their own class.

Root-of-unity tests are exact where the degrees allow it: the ratios
``theta'/theta`` of roots of ``f`` and ``g`` are the roots of
``Res_y(f(y), g(x y))``, and its cyclotomic factors ``Phi_m`` are exactly the
orders that occur (MATH.md section 2).  Which pairs carry which order is read
from 60-digit certified roots, and must agree with the resultant.

The reduced block (Definition 4) uses only eigenvectors: the heads of all
Jordan chains of ``theta`` span ``ker(A - theta I)``, so
``C_hat_k = [C E_theta1, C E_theta2, ...]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction
from functools import reduce
from typing import Any, Iterable, Optional, Sequence

import mpmath
import numpy as np
from sympy import QQ, Poly, resultant, symbols
from sympy.polys.matrices import DomainMatrix

from .._budget import Budget
from ..errors import NumericalFailure
from ..model._exact import fraction_text
from ..model._types import Matrix, System, to_domain
from ._algebraic import AlgebraicReal, power_minus, real_root_matching
from ._eigen import DIGITS, EigenFactor, X, eigen_factors
from ._phases import PhaseBlock, Slot

_Y = symbols("y")
#: Largest ``deg f * deg g`` for which the resultant test is run exactly.
MAX_RESULTANT_DEGREE = 144
#: Largest degree of a compositum field used for exact ranks.
MAX_EXACT_FIELD_DEGREE = 48
#: Largest ``deg f`` for which ``|theta|^2`` of a non-real root is made exact.
MAX_MODULUS_DEGREE = 10

Root = tuple[int, int]  # (factor index, index into EigenFactor.roots)


@dataclass(frozen=True)
class FmoBlock:
    """One FMO block: its eigenvalues, modulus, Jordan structure and phase form.

    Attributes
    ----------
    members:
        The distinct eigenvalues of the class, as (factor index, root index).
    eigenvalue_texts:
        Exact text of each member (``"5/4"``, ``"1 - I"``, ``"root of x**4 + 81/16 near ..."``).
    eigenvalue_values:
        Numerical value of each member (complex).
    jordan_sizes:
        Sizes of all Jordan cells of the class (members in order).
    modulus_sq:
        ``beta = |alpha_k|^2`` exactly (or ``None`` when it could not be made
        exact; then ``modulus_sq_float`` is all there is).
    phase:
        The reduced block in phase form, or ``None`` for the zero class.
    certified:
        Whether the class structure (root-of-unity relations) was decided
        exactly.
    """

    members: tuple[Root, ...]
    eigenvalue_texts: tuple[str, ...]
    eigenvalue_values: tuple[complex, ...]
    jordan_sizes: tuple[int, ...]
    modulus_sq: AlgebraicReal | None
    modulus_sq_float: float
    phase: PhaseBlock | None
    certified: bool
    notes: tuple[str, ...] = field(default=())

    @property
    def modulus(self) -> float:
        return math.sqrt(self.modulus_sq_float)

    @property
    def is_zero(self) -> bool:
        return self.modulus_sq_float == 0.0


# ---------------------------------------------------------------------------
# Root-of-unity relations


def _cyclotomic_orders(f: Poly, g: Poly) -> set[int]:
    """Orders ``m`` such that some ``theta_g / theta_f`` is a primitive ``m``-th root of unity.

    Exact: the cyclotomic factors of ``Res_y(f(y), g(x y))``.
    """
    F = Poly(f.as_expr().subs(X, _Y), _Y, X)
    G = Poly(g.as_expr().subs(X, X * _Y), _Y, X)
    R = Poly(resultant(F, G, _Y), X, domain=QQ)
    orders = set()
    for h, _ in R.factor_list()[1]:
        if h.is_cyclotomic:
            d = int(h.degree())
            m = _cyclotomic_index(h, d)
            orders.add(m)
    return orders


def _cyclotomic_index(h: Poly, d: int) -> int:
    from sympy import cyclotomic_poly

    for m in range(1, 2 * d * d + 3):
        if _euler_phi(m) == d and Poly(cyclotomic_poly(m, X), X, domain=QQ) == h.monic():
            return m
    raise NumericalFailure("cyclotomic factor of unknown order")  # pragma: no cover


def _euler_phi(m: int) -> int:
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


def _order_of_ratio(r: mpmath.mpc, max_order: int) -> tuple[int, int] | None:
    """``(m, k)`` with ``r = exp(2 pi i k / m)`` to 40 digits, ``m <= max_order``, else ``None``."""
    with mpmath.workdps(DIGITS + 10):
        if abs(abs(r) - 1) > mpmath.mpf(10) ** -40:
            return None
        t = mpmath.arg(r) / (2 * mpmath.pi)
        t = t - mpmath.floor(t)
        approx = Fraction(str(mpmath.nstr(t, DIGITS))).limit_denominator(max_order)
        if abs(t - mpmath.mpf(approx.numerator) / approx.denominator) > mpmath.mpf(10) ** -40:
            return None
        if approx.numerator == approx.denominator:
            return (1, 0)
        return (approx.denominator, approx.numerator % approx.denominator)


class _UnionFind:
    def __init__(self, items: Iterable[Root]) -> None:
        self.parent = {x: x for x in items}

    def find(self, x: Root) -> Root:
        while self.parent[x] != x:
            self.parent[x] = self.parent[self.parent[x]]
            x = self.parent[x]
        return x

    def union(self, a: Root, b: Root) -> None:
        ra, rb = self.find(a), self.find(b)
        if ra != rb:
            self.parent[max(ra, rb)] = min(ra, rb)


def fmo_classes(
    factors: Sequence[EigenFactor], budget: Budget | None = None
) -> tuple[list[list[Root]], dict[tuple[Root, Root], tuple[int, int]], bool, list[str]]:
    """Partition the non-zero eigenvalues into FMO classes.

    Returns the classes, the relation ``(u, v) -> (m, k)`` meaning
    ``v / u = exp(2 pi i k / m)``, whether every relation (and non-relation)
    was certified by the resultant test, and notes.
    """
    roots: list[tuple[Root, mpmath.mpc]] = []
    for fi, f in enumerate(factors):
        if f.is_zero:
            continue
        roots.extend(((fi, ri), val) for ri, val in enumerate(f.roots))
    uf = _UnionFind(r for r, _ in roots)
    relation: dict[tuple[Root, Root], tuple[int, int]] = {}
    found_orders: dict[tuple[int, int], set[int]] = {}
    candidate_pairs: set[tuple[int, int]] = set()
    tol = mpmath.mpf(10) ** -40
    for a in range(len(roots)):
        (ua, va) = roots[a]
        for b in range(a + 1, len(roots)):
            (ub, vb) = roots[b]
            if budget is not None:
                budget.tick("FMO classes")
            with mpmath.workdps(DIGITS + 10):
                if abs(abs(va) - abs(vb)) > tol * abs(va):
                    continue
                ratio = vb / va
            key = (min(ua[0], ub[0]), max(ua[0], ub[0]))
            candidate_pairs.add(key)
            da, db = factors[ua[0]].degree, factors[ub[0]].degree
            max_order = 2 * (da * db) ** 2 + 2
            rel = _order_of_ratio(ratio, max_order)
            if rel is None:
                continue
            m, k = rel
            relation[(ua, ub)] = (m, k)
            relation[(ub, ua)] = (m, (-k) % m)
            uf.union(ua, ub)
            found_orders.setdefault(key, set()).add(m)
    certified = True
    notes: list[str] = []
    for fa, fb in sorted(candidate_pairs):
        f, g = factors[fa].poly, factors[fb].poly
        if f.degree() * g.degree() > MAX_RESULTANT_DEGREE:
            certified = False
            notes.append(
                f"root-of-unity relations between factors of degree {f.degree()} and {g.degree()} "
                "were decided with 60-digit certified roots only (no exact resultant test)"
            )
            continue
        if budget is not None:
            budget.tick("resultant test", 16)
        exact = _cyclotomic_orders(f, g)
        if fa == fb:
            exact.discard(1)  # theta / theta
        if exact != found_orders.get((fa, fb), set()):
            raise NumericalFailure(
                f"root-of-unity orders disagree between the resultant {sorted(exact)} and the "
                f"numerical roots {sorted(found_orders.get((fa, fb), set()))}"
            )
    groups: dict[Root, list[Root]] = {}
    for r, _ in roots:
        groups.setdefault(uf.find(r), []).append(r)
    classes = [sorted(g) for g in groups.values()]
    classes.sort(key=lambda c: c[0])
    return classes, relation, certified, notes


# ---------------------------------------------------------------------------
# |alpha|^2 exactly


def _companion(f: Poly) -> DomainMatrix:
    c = [QQ.convert(x) for x in f.monic().all_coeffs()]
    d = len(c) - 1
    rows = [[QQ(0)] * d for _ in range(d)]
    for i in range(1, d):
        rows[i][i - 1] = QQ(1)
    for i in range(d):
        rows[i][d - 1] = -c[d - i]
    return DomainMatrix(rows, (d, d), QQ)


def _kron(a: DomainMatrix, b: DomainMatrix) -> DomainMatrix:
    la, lb = a.to_list(), b.to_list()
    n, m = len(la), len(lb)
    rows = [[la[i // m][j // m] * lb[i % m][j % m] for j in range(n * m)] for i in range(n * m)]
    return DomainMatrix(rows, (n * m, n * m), QQ)


def modulus_squared(f: EigenFactor, index: int) -> AlgebraicReal | None:
    """``|theta|^2`` exactly for root ``index`` of ``f``.

    Rational ``theta``: ``theta^2``.  Real ``theta``: a root of
    ``charpoly(C_f^2)``.  Non-real ``theta``: ``theta * conj(theta)`` is a
    root of ``charpoly(C_f (x) C_f)`` (eigenvalues ``theta_i theta_j``); the
    irreducible factor that has it as a real root is its minimal polynomial.
    Returns ``None`` when ``deg f`` exceeds :data:`MAX_MODULUS_DEGREE` for a
    non-real root.
    """
    if f.is_rational:
        return AlgebraicReal.of_rational(f.rational_root**2)
    theta = f.roots[index]
    with mpmath.workdps(DIGITS + 10):
        target = abs(theta) ** 2
    is_real = f.is_real_root(index)
    if is_real:
        M = _companion(f.poly)
        M = M * M
    elif f.degree <= MAX_MODULUS_DEGREE:
        M = _kron(_companion(f.poly), _companion(f.poly))
    else:
        return None
    P = Poly(M.charpoly(), X, domain=QQ)
    for h, _ in P.factor_list()[1]:
        h = h.monic()
        if h.degree() == 1:
            c = -h.TC()
            val = Fraction(int(c.numerator), int(c.denominator))
            with mpmath.workdps(DIGITS + 10):
                if abs(mpmath.mpf(val.numerator) / val.denominator - target) < mpmath.mpf(10) ** -(DIGITS // 2) * max(
                    1, target
                ):
                    return AlgebraicReal.of_rational(val)
            continue
        idx = real_root_matching(h, target)
        if idx is not None:
            return AlgebraicReal(minpoly=h, index=idx)
    raise NumericalFailure("|theta|^2 matches no factor of its polynomial")  # pragma: no cover


# ---------------------------------------------------------------------------
# Reduced blocks in phase form


def _eigen_text(f: EigenFactor, index: int) -> str:
    """Exact text of a root: rational, quadratic radicals, else its polynomial and a numerical value."""
    if f.is_rational:
        return fraction_text(f.rational_root)
    if f.degree == 2:
        from sympy import roots as radical_roots

        target = f.roots[index]
        for r in radical_roots(f.poly):
            with mpmath.workdps(DIGITS):
                val = mpmath.mpc(*[mpmath.mpf(str(x)) for x in r.evalf(DIGITS).as_real_imag()])
                if abs(val - target) < mpmath.mpf(10) ** -(DIGITS // 2) * max(1, abs(target)):
                    return str(r)
    z = complex(f.roots[index])
    return f"root of {f.poly.as_expr()} near {z.real:.12g}{z.imag:+.12g}i"


class _ExactRows:
    """Exact rank oracle over a number field containing every member of a class."""

    def __init__(
        self, K: Any, columns: list[list[Any]], omegas: list[Any], groups: Sequence[Sequence[int]], period: int
    ) -> None:
        self.K = K
        self.columns = columns  # per column: p entries in K
        self.omegas = omegas  # per column: omega_j in K
        self.groups = groups
        self.period = period
        self._cache: dict[int, list[list[Any]]] = {}

    def _rows(self, n: int) -> list[list[Any]]:
        n %= self.period
        if n not in self._cache:
            K = self.K
            pw = [K.one] * len(self.omegas)
            for j, w in enumerate(self.omegas):
                for _ in range(n):
                    pw[j] = pw[j] * w
            p = len(self.columns[0]) if self.columns else 0
            self._cache[n] = [[self.columns[j][i] * pw[j] for j in range(len(self.columns))] for i in range(p)]
        return self._cache[n]

    def __call__(self, slots: Iterable[Slot]) -> int | None:
        rows: list[list[Any]] = []
        for n, g in slots:
            r = self._rows(n)
            rows.extend(r[i] for i in self.groups[g])
        if not rows:
            return 0
        return int(DomainMatrix(rows, (len(rows), len(self.columns)), self.K).rank())


def _cyclotomic_form(
    members: Sequence[Root], factors: Sequence[EigenFactor], beta: Optional[AlgebraicReal]
) -> Optional[tuple[Fraction, int, list[int]]]:
    """``(beta, L, k)`` with ``theta_j = sqrt(beta) * exp(2 pi i k_j / L)``, ``beta`` rational, if the class has that form.

    Certified: ``theta_j / sqrt(beta)`` is a root of unity of order dividing
    ``2 m`` iff ``f_j`` divides ``x^(2m) - beta^m``; which root it is comes from
    the 60-digit roots.
    """
    if beta is None or beta.rational is None or beta.rational == 0:
        return None
    b = beta.rational
    orders = []
    with mpmath.workdps(DIGITS + 10):
        r = mpmath.sqrt(mpmath.mpf(b.numerator) / b.denominator)
        for fi, ri in members:
            f = factors[fi]
            rel = _order_of_ratio(f.roots[ri] / r, 2 * f.degree**2 + 2)
            if rel is None:
                return None
            m, k = rel
            target = power_minus(2 * m, QQ(b.numerator**m, b.denominator**m))
            if not target.rem(f.poly).is_zero:
                return None
            orders.append((m, k))
    L = reduce(math.lcm, (m for m, _ in orders), 1)
    return b, L, [k * (L // m) % L for m, k in orders]


def _member_field_and_values(
    members: Sequence[Root], factors: Sequence[EigenFactor], beta: AlgebraicReal | None
) -> tuple[Any, dict[Root, Any]]:
    """A number field containing every member, and each member's value in it.

    Two exact cases cover the systems met in practice:

    * every member is ``sqrt(beta) * zeta^k`` with ``beta`` rational (real
      rational eigenvalues, rotations by rational angles, ``1 +- i``): the
      field ``Q(sqrt(beta), zeta_L)``;
    * the class is a single eigenvalue ``theta``: its own field ``Q(theta)``.

    Otherwise ``(None, {})``: ranks stay numerical and are reported as such.
    """
    from sympy import I, Rational, exp, pi, sqrt

    form = _cyclotomic_form(members, factors, beta)
    if form is not None:
        b, L, ks = form
        r_expr = sqrt(Rational(b.numerator, b.denominator))
        gens = ([] if r_expr.is_Rational else [r_expr]) + ([exp(2 * pi * I / L)] if L > 2 else [])
        if _euler_phi(L) * (1 if r_expr.is_Rational else 2) <= MAX_EXACT_FIELD_DEGREE:
            K = QQ.algebraic_field(*gens) if gens else QQ
            zeta = K.from_sympy(exp(2 * pi * I / L)) if L > 2 else K.convert(QQ(-1) if L == 2 else QQ(1))
            rq = K.from_sympy(r_expr)
            values = {}
            for root, k in zip(members, ks):
                v = rq
                for _ in range(k):
                    v = v * zeta
                values[root] = v
            return K, values
    if len(members) == 1:
        f = factors[members[0][0]]
        K = f.field
        return K, {members[0]: K.from_sympy(K.ext) if K != QQ else QQ.convert(-f.poly.TC())}
    return None, {}


def build_block(
    members: Sequence[Root],
    relation: dict[tuple[Root, Root], tuple[int, int]],
    factors: Sequence[EigenFactor],
    C: Matrix,
    row_groups: tuple[tuple[int, ...], ...],
    certified: bool,
    notes: Sequence[str],
) -> FmoBlock:
    """Reduced FMO block (seed 001, Definition 4) of one class, in phase form."""
    head = members[0]
    fi0, ri0 = head
    texts = tuple(_eigen_text(factors[fi], ri) for fi, ri in members)
    values = tuple(complex(factors[fi].roots[ri]) for fi, ri in members)
    sizes = tuple(s for fi, _ in members for s in factors[fi].jordan_sizes)
    mod_sq = modulus_squared(factors[fi0], ri0)
    with mpmath.workdps(DIGITS + 10):
        mod_sq_float = float(abs(factors[fi0].roots[ri0]) ** 2)
    block_notes = list(notes)
    if mod_sq is None:
        block_notes.append("|alpha|^2 is known to 60 digits but not as an exact algebraic number")
    orders = [relation[(head, m)] if m != head else (1, 0) for m in members]
    N0 = reduce(math.lcm, (m for m, _ in orders), 1)
    member_exp = [k * (N0 // m) % N0 for m, k in orders]

    Cd = to_domain(C)
    p = len(C)
    columns_num: list[np.ndarray] = []
    exponents: list[int] = []
    exact_cols: list[tuple[Root, list[list[Fraction]]]] = []
    for (fi, ri), e in zip(members, member_exp):
        f = factors[fi]
        CV = Cd.convert_to(f.field) * f.eigvecs.transpose()  # p x g, exact over Q(theta)
        cols = CV.transpose().to_list()
        with mpmath.workdps(DIGITS + 10):
            for col in cols:
                coeffs = [f.coeffs_of(x) for x in col]
                exact_cols.append(((fi, ri), coeffs))
                v = np.array([complex(f.value_at(cs, ri)) for cs in coeffs], dtype=complex)
                nrm = np.linalg.norm(v)
                columns_num.append(v / nrm if nrm > 0 else v)
                exponents.append(e)
    c_hat = np.column_stack(columns_num) if columns_num else np.zeros((p, 0), dtype=complex)

    oracle = None
    try:
        K, member_vals = _member_field_and_values(members, factors, mod_sq)
    except Exception:  # noqa: BLE001 - SymPy may fail to build a large compositum
        K, member_vals = None, {}
    if K is not None:
        theta0 = member_vals[head]
        omegas_m = {r: member_vals[r] / theta0 for r in members}
        cols_k: list[list[Any]] = []
        omegas: list[Any] = []
        for root, coeffs in exact_cols:
            t = member_vals[root]
            col = []
            for cs in coeffs:
                acc = K.zero
                for c in reversed(cs):
                    acc = acc * t + K.convert(QQ(c.numerator, c.denominator))
                col.append(acc)
            cols_k.append(col)
            omegas.append(omegas_m[root])
        oracle = _ExactRows(K, cols_k, omegas, row_groups, N0)
    else:
        block_notes.append("ranks of this block are numerical: its number field is too large for exact arithmetic")
    phase = PhaseBlock(
        base_period=N0, exponents=tuple(exponents), c_hat=c_hat, row_groups=row_groups, exact_rank=oracle
    )
    return FmoBlock(
        members=tuple(members),
        eigenvalue_texts=texts,
        eigenvalue_values=values,
        jordan_sizes=sizes,
        modulus_sq=mod_sq,
        modulus_sq_float=mod_sq_float,
        phase=phase,
        certified=certified,
        notes=tuple(block_notes),
    )


def fmo_blocks(system: System, budget: Budget | None = None) -> list[FmoBlock]:
    """All FMO blocks of ``system``, largest modulus first; the zero class last.

    Examples
    --------
    >>> from fractions import Fraction as F
    >>> from kfio.model._types import System
    >>> s = System(A=((F(2), F(0)), (F(0), F(-2))), C=((F(1), F(1)),))
    >>> [(b.eigenvalue_texts, b.phase.base_period) for b in fmo_blocks(s)]
    [(('2', '-2'), 2)]
    """
    factors = eigen_factors(system.A)
    if system.sensors is None:
        groups: tuple[tuple[int, ...], ...] = (tuple(range(system.p)),)
    else:
        groups = tuple(s.rows for s in system.sensors)
    classes, relation, certified, notes = fmo_classes(factors, budget)
    blocks = [build_block(c, relation, factors, system.C, groups, certified, notes) for c in classes]
    blocks.sort(key=lambda b: -b.modulus_sq_float)
    for fi, f in enumerate(factors):
        if f.is_zero:
            blocks.append(
                FmoBlock(
                    members=((fi, 0),),
                    eigenvalue_texts=("0",),
                    eigenvalue_values=(0j,),
                    jordan_sizes=f.jordan_sizes,
                    modulus_sq=AlgebraicReal.of_rational(Fraction(0)),
                    modulus_sq_float=0.0,
                    phase=None,
                    certified=True,
                )
            )
    return blocks
