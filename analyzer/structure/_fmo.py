"""FMO blocks (Rohr, Marelli and Fu (2014), Definitions 3-5) and their phase form.

Eigenvalues ``theta_i ~ theta_j`` when ``theta_i / theta_j`` is a root of
unity (they have a *finite multiplicative order* up to a constant).  A class
has one modulus ``|alpha_k|``; zero eigenvalues form their own class.

Root-of-unity relations and non-relations are proved at every size from
certified root enclosures (:mod:`kfio.structure._unity`): provably different
moduli settle a pair at once, the argument of a ratio leaves at most one
candidate order, and that candidate is confirmed or refuted exactly.  The
previous route (60-digit roots checked against the cyclotomic factors of
``Res_y(f(y), g(x y))`` when ``deg f * deg g <= 144``) is kept as a
test oracle in ``tests/support/fmo_resultant.py``.

The reduced block (Definition 4) uses only eigenvectors: the heads of all
Jordan chains of ``theta`` span ``ker(A - theta I)``, so
``C_hat_k = [C E_theta1, C E_theta2, ...]``.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass, field
from fractions import Fraction
from functools import cached_property, reduce
from typing import Any, Callable, Iterable, Optional, Sequence

import mpmath
import numpy as np
from flint import arb, fmpq, fmpq_mat, fmpq_poly
from sympy import QQ
from sympy.polys.matrices import DomainMatrix
from sympy.polys.polyerrors import BasePolynomialError

from .._budget import Budget
from ..model import Matrix, fraction_text
from ..model import SystemRecord as System
from ._adjugate import to_fmpq_mat
from ._algebraic import AlgebraicReal, power_minus
from ._balls import MAX_PREC, START_PREC, horner, precision, sign, to_float
from ._cyclotomic_rank import CyclotomicRows, cyclotomic
from ._eigen import DIGITS, EigenFactor, eigen_factors
from ._modp import ModP
from ._modulus import modulus_squared
from ._phases import PhaseBlock, RankOracle, Slot
from ._texts import poly_text
from ._unity import Root as UnityRoot
from ._unity import euler_phi, ratio_relation

#: Largest degree of a compositum field used for exact ranks.
MAX_EXACT_FIELD_DEGREE = 48

#: Coefficients longer than this (bits) are not written out: Python refuses int-to-text past 4300 digits.
_TEXT_BITS = 12000

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
    modulus_sq_ball:
        ``prec -> `` certified enclosure (flint ``arb``) of ``beta`` at
        ``prec`` bits, or ``None`` for the zero class.
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
    modulus_sq_ball: Callable[[int], Any] | None = field(default=None, compare=False, repr=False)

    @property
    def modulus(self) -> float:
        return math.sqrt(self.modulus_sq_float)

    def compare_power(self, N: int, c: Fraction) -> tuple[int, bool]:
        """Sign of ``beta^N - c`` and whether it is proved.

        Exact through :attr:`modulus_sq` when known; otherwise from the
        enclosure :attr:`modulus_sq_ball`, refined up to :data:`MAX_PREC`
        bits, which proves every strict inequality but never an equality.
        """
        if self.modulus_sq is not None:
            return self.modulus_sq.compare_power(N, c), True
        if self.modulus_sq_ball is not None:
            prec = START_PREC
            while prec <= MAX_PREC:
                with precision(prec):
                    s = sign(self.modulus_sq_ball(prec) ** N - arb(fmpq(c.numerator, c.denominator)))
                if s:
                    return s, True
                prec *= 4
        with mpmath.workdps(DIGITS):
            v = mpmath.mpf(self.modulus_sq_float) ** N - mpmath.mpf(c.numerator) / c.denominator
        return (0 if abs(v) <= 1e-30 else (1 if v > 0 else -1)), False

    @property
    def is_zero(self) -> bool:
        return self.modulus_sq_float == 0.0


# ---------------------------------------------------------------------------
# Root-of-unity relations


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


def _root_handle(f: EigenFactor, ri: int) -> UnityRoot:
    return UnityRoot(f.int_coeffs, lambda prec: f.root_ball(ri, prec))


def fmo_classes(
    factors: Sequence[EigenFactor], budget: Budget | None = None
) -> tuple[list[list[Root]], dict[tuple[Root, Root], tuple[int, int]], bool, list[str]]:
    """Partition the non-zero eigenvalues into FMO classes, every relation and non-relation proved.

    Rohr, Marelli and Fu (2014), Definition 3.  Pairs whose moduli are
    provably different (disjoint enclosures of ``|theta|^2``) are settled
    at once; the others by :func:`kfio.structure._unity.ratio_relation`
    (one candidate order from the enclosure of the ratio's argument, then an
    exact test).

    Returns
    -------
    classes, relation, certified, notes
        The classes (sorted lists of roots), the relation ``(u, v) -> (m,
        k)`` meaning ``v / u = exp(2 pi i k / m)``, whether every decision
        was certified, and notes for the report.
    """
    roots: list[Root] = [(fi, ri) for fi, f in enumerate(factors) if not f.is_zero for ri in range(f.degree)]
    uf = _UnionFind(roots)
    relation: dict[tuple[Root, Root], tuple[int, int]] = {}
    with precision(START_PREC):
        mod2 = {}
        for fi, ri in roots:
            z = factors[fi].root_ball(ri)
            mod2[(fi, ri)] = (z * z.conjugate()).real
    certified = True
    notes: list[str] = []
    for a, ua in enumerate(roots):
        for ub in roots[a + 1 :]:
            if budget is not None:
                budget.tick("FMO classes")
            # provably different moduli, or already related through other members
            if not mod2[ua].overlaps(mod2[ub]) or uf.find(ua) == uf.find(ub):
                continue
            bound = factors[ua[0]].degree * factors[ub[0]].degree
            rel, decided = ratio_relation(
                _root_handle(factors[ua[0]], ua[1]), _root_handle(factors[ub[0]], ub[1]), bound
            )
            if not decided:  # pragma: no cover - MAX_PREC bits always sufficed
                certified = False
                notes.append("a root-of-unity relation could not be decided at the largest precision")
                continue
            if rel is None:
                continue
            m, k = rel
            relation[(ua, ub)] = (m, k)
            relation[(ub, ua)] = (m, (-k) % m)
            uf.union(ua, ub)
    _close_relations(relation, uf, roots)
    groups: dict[Root, list[Root]] = {}
    for r in roots:
        groups.setdefault(uf.find(r), []).append(r)
    classes = [sorted(g) for g in groups.values()]
    classes.sort(key=lambda c: c[0])
    return classes, relation, certified, notes


def _close_relations(relation: dict[tuple[Root, Root], tuple[int, int]], uf: _UnionFind, roots: list[Root]) -> None:
    """Make ``relation`` hold every pair (head, member) of each class, composing known relations.

    Ratios compose: ``w / u = (w / v)(v / u)``, so ``k_uw / m_uw = k_uv / m_uv + k_vw / m_vw`` mod 1.
    """
    members: dict[Root, list[Root]] = {}
    for r in roots:
        members.setdefault(uf.find(r), []).append(r)
    for group in members.values():
        head = min(group)
        turns = {head: Fraction(0)}
        frontier = [head]
        while frontier:
            u = frontier.pop()
            for v in group:
                if v in turns or (u, v) not in relation:
                    continue
                m, k = relation[(u, v)]
                turns[v] = (turns[u] + Fraction(k, m)) % 1
                frontier.append(v)
        for v, t in turns.items():
            if v != head and (head, v) not in relation:
                relation[(head, v)] = (t.denominator, t.numerator)
                relation[(v, head)] = (t.denominator, (-t.numerator) % t.denominator)


# ---------------------------------------------------------------------------
# Reduced blocks in phase form


def _eigen_text(f: EigenFactor, index: int) -> str:
    """Exact text of a root: rational, quadratic radicals, else its polynomial and a numerical value.

    The polynomial is written as SymPy prints ``f.poly.as_expr()`` (:func:`kfio.structure._texts.poly_text`).
    """
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
    bits = max(max(int(c.numerator).bit_length(), int(c.denominator).bit_length()) for c in f.poly.all_coeffs())
    if bits > _TEXT_BITS:  # beyond Python's int-to-text limit: describe the polynomial instead
        return f"root of a degree-{f.degree} polynomial with {bits}-bit coefficients near {z.real:.12g}{z.imag:+.12g}i"
    return f"root of {_poly_text_of(f)} near {z.real:.12g}{z.imag:+.12g}i"


_POLY_TEXTS: dict[int, tuple[weakref.ref[Any], str]] = {}


def _poly_text_of(f: EigenFactor) -> str:
    """SymPy's text of ``f.poly.as_expr()``, kept for the last factors seen (one text serves all ``deg f`` roots).

    The factor is held by a weak reference: the cache never keeps a system's eigenstructure alive.
    """
    hit = _POLY_TEXTS.get(id(f))
    if hit is not None and hit[0]() is f:
        return hit[1]
    coeffs = [Fraction(int(c.numerator), int(c.denominator)) for c in f.poly.all_coeffs()]
    text = poly_text(coeffs)
    if len(_POLY_TEXTS) > 64:
        _POLY_TEXTS.clear()
    _POLY_TEXTS[id(f)] = (weakref.ref(f), text)
    return text


class _SingleRows:
    """Exact rank oracle of a one-eigenvalue class (``omega = 1``: every phase has the same rows).

    Entries are polynomials in ``theta`` of degree ``< deg f`` with rational
    coefficients; ``1, theta, ..., theta^(d-1)`` is a basis of ``Q(theta)``,
    so an entry is zero iff its coefficients are.  With one column (a simple
    eigenvalue) the rank is 1 iff a selected entry is non-zero: no number
    field arithmetic at all.  Several columns use ``DomainMatrix`` over
    ``Q(theta)``.
    """

    def __init__(self, f: EigenFactor, columns: list[list[list[Fraction]]], groups: Sequence[Sequence[int]]) -> None:
        self.f = f
        self.columns = columns  # per column: p entries, each a coefficient list
        self.groups = groups
        self._cache: dict[frozenset[int], int] = {}

    def _rank(self, rows: frozenset[int]) -> int:
        if not rows:
            return 0
        if len(self.columns) == 1:
            return int(any(any(c != 0 for c in self.columns[0][i]) for i in rows))
        K = self.f.field
        if K == QQ:
            entries = [[QQ(col[i][0].numerator, col[i][0].denominator) for col in self.columns] for i in sorted(rows)]
        else:
            entries = [
                [K.new([QQ(c.numerator, c.denominator) for c in reversed(col[i])]) for col in self.columns]
                for i in sorted(rows)
            ]
        return int(DomainMatrix(entries, (len(entries), len(self.columns)), K).rank())

    def __call__(self, slots: Iterable[Slot]) -> int | None:
        rows = frozenset(i for _, g in slots for i in self.groups[g])
        if rows not in self._cache:
            self._cache[rows] = self._rank(rows)
        return self._cache[rows]


def _field_power(K: Any, w: Any, n: int) -> Any:
    """``w^n`` in the field ``K`` by repeated squaring (exact: the same element as ``n`` products)."""
    out, base = K.one, w
    while n:
        if n & 1:
            out = out * base
        n >>= 1
        if n:
            base = base * base
    return out


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
        self._power_cache: dict[int, list[Any]] = {0: [K.one] * len(omegas)}
        self._reduced: dict[int, list[list[int]] | None] = {}

    @cached_property
    def _modp(self) -> ModP | None:
        """The reduction modulo a prime of degree one, found on the first rank asked."""
        return ModP.for_field(self.K)

    def _powers(self, n: int) -> list[Any]:
        """``omega_j^n`` per column, from the cached powers of phase ``n - 1`` when there (one product each)."""
        if n not in self._power_cache:
            before = self._power_cache.get(n - 1)
            if before is not None:
                self._power_cache[n] = [a * w for a, w in zip(before, self.omegas)]
            else:
                self._power_cache[n] = [_field_power(self.K, w, n) for w in self.omegas]
        return self._power_cache[n]

    def _rows(self, n: int) -> list[list[Any]]:
        n %= self.period
        if n not in self._cache:
            pw = self._powers(n)
            p = len(self.columns[0]) if self.columns else 0
            self._cache[n] = [[self.columns[j][i] * pw[j] for j in range(len(self.columns))] for i in range(p)]
        return self._cache[n]

    @cached_property
    def _reduced_factors(self) -> tuple[list[list[int]], list[int]] | None:
        """The columns (``p x L``) and the ``omega_j`` modulo the prime of :class:`ModP`, ``None`` if one does not reduce."""
        assert self._modp is not None
        p = len(self.columns[0]) if self.columns else 0
        cols = self._modp.matrix([[self.columns[j][i] for j in range(len(self.columns))] for i in range(p)])
        omegas = self._modp.matrix([self.omegas])
        return None if cols is None or omegas is None else (cols, omegas[0])

    def _reduced_rows(self, n: int) -> list[list[int]] | None:
        """The rows of phase ``n`` modulo the prime of :class:`ModP` (``None`` if one does not reduce).

        Reduction is a ring homomorphism on the ``p``-integral elements, so the image of
        ``c_ij omega_j^n`` is ``red(c_ij) red(omega_j)^n``: no arithmetic in the field.
        """
        n %= self.period
        if n not in self._reduced:
            assert self._modp is not None
            factors = self._reduced_factors
            if factors is not None:
                prime = self._modp.p
                cols, omegas = factors
                pw = [pow(w, n, prime) for w in omegas]
                self._reduced[n] = [[c * w % prime for c, w in zip(row, pw)] for row in cols]
            else:
                self._reduced[n] = self._modp.matrix(self._rows(n))
        return self._reduced[n]

    def __call__(self, slots: Iterable[Slot]) -> int | None:
        slots = list(slots)
        rows: list[list[Any]] = []
        for n, g in slots:
            r = self._rows(n)
            rows.extend(r[i] for i in self.groups[g])
        if not rows:
            return 0
        L = len(self.columns)
        if self._modp is not None and len(rows) >= L:
            # Full rank modulo a prime of degree one is full rank (module _modp);
            # anything less is decided over Q(theta).
            red: list[list[int]] = []
            for n, g in slots:
                images = self._reduced_rows(n)
                if images is None:
                    break
                red.extend(images[i] for i in self.groups[g])
            else:
                if self._modp.rank(red, L) == L:
                    return L
        return int(DomainMatrix(rows, (len(rows), L), self.K).rank())


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
    divides: dict[tuple[int, int], bool] = {}  # (factor, m) -> f | x^(2m) - beta^m: one test per factor, not per root
    with mpmath.workdps(DIGITS + 10):
        r = mpmath.sqrt(mpmath.mpf(b.numerator) / b.denominator)
        for fi, ri in members:
            f = factors[fi]
            rel = _order_of_ratio(f.roots[ri] / r, 2 * f.degree**2 + 2)
            if rel is None:
                return None
            m, k = rel
            if (fi, m) not in divides:
                target = power_minus(2 * m, QQ(b.numerator**m, b.denominator**m))
                divides[(fi, m)] = target.rem(f.poly).is_zero
            if not divides[(fi, m)]:
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
        if euler_phi(L) * (1 if r_expr.is_Rational else 2) <= MAX_EXACT_FIELD_DEGREE:
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


def _cyclotomic_oracle(
    members: Sequence[Root],
    factors: Sequence[EigenFactor],
    beta: AlgebraicReal | None,
    exact_cols: Sequence[tuple[Root, list[list[Fraction]]]],
    row_groups: Sequence[Sequence[int]],
    period: int,
) -> CyclotomicRows | None:
    """The FLINT rank oracle over ``Q(zeta_L)`` when every member is ``r zeta_L^k`` with ``r`` rational, ``L > 2``.

    The same class of blocks as the first case of :func:`_member_field_and_values` with a
    rational ``sqrt(beta)``, and the same field-degree limit: column ``j`` of member
    ``theta = r zeta_L^k`` is ``C v(theta)``, the polynomial ``sum_t c_t r^t y^(t k)``
    reduced modulo ``Phi_L``, and ``omega_j = theta / theta_head = zeta_L^(k - k_head)``.
    ``None`` for every other class (the SymPy route decides those).
    """
    form = _cyclotomic_form(members, factors, beta)
    if form is None:
        return None
    b, L, ks = form
    num, den = math.isqrt(b.numerator), math.isqrt(b.denominator)
    if num * num != b.numerator or den * den != b.denominator or L <= 2 or euler_phi(L) > MAX_EXACT_FIELD_DEGREE:
        return None
    r = fmpq(num, den)
    k_of = dict(zip(members, ks))
    phi = cyclotomic(L)
    weighted: dict[int, list[fmpq]] = {}  # id of a coefficient list -> c_t r^t (the roots of one factor share it)
    columns = []
    exponents = []
    for root, coeffs in exact_cols:
        k = k_of[root]
        col = []
        for cs in coeffs:
            if id(cs) not in weighted:
                power, w = fmpq(1), []
                for c in cs:
                    w.append(fmpq(c.numerator, c.denominator) * power)
                    power *= r
                weighted[id(cs)] = w
            acc = [fmpq(0)] * L
            for t, wt in enumerate(weighted[id(cs)]):
                acc[t * k % L] += wt
            col.append(fmpq_poly(acc) % phi)
        columns.append(col)
        exponents.append((k - ks[0]) % L)
    return CyclotomicRows(L, columns, exponents, row_groups, period)


def _output_columns(Cq: fmpq_mat, f: EigenFactor, p: int) -> list[list[list[Fraction]]]:
    """``C v`` for every eigenvector polynomial ``v(theta)`` of ``f``: per vector, per output row, the coefficients."""
    out = []
    for vec in f.eigvec_coeffs:
        d = len(vec[0])
        CB = Cq * fmpq_mat(len(vec), d, [fmpq(c.numerator, c.denominator) for comp in vec for c in comp])
        entries = CB.entries()
        out.append([[Fraction(int(x.p), int(x.q)) for x in entries[i * d : (i + 1) * d]] for i in range(p)])
    return out


def build_block(
    members: Sequence[Root],
    relation: dict[tuple[Root, Root], tuple[int, int]],
    factors: Sequence[EigenFactor],
    C: Matrix,
    row_groups: tuple[tuple[int, ...], ...],
    certified: bool,
    notes: Sequence[str],
    columns: dict[int, list[list[list[Fraction]]]] | None = None,
) -> FmoBlock:
    """Reduced FMO block (Rohr, Marelli and Fu (2014), Definition 4) of one class, in phase form.

    ``columns`` caches, per factor index, the exact ``C v(theta)`` coefficient
    lists of :func:`_output_columns` across the blocks of one system.
    """
    head = members[0]
    fi0, ri0 = head
    texts = tuple(_eigen_text(factors[fi], ri) for fi, ri in members)
    values = tuple(complex(factors[fi].roots[ri]) for fi, ri in members)
    sizes = tuple(s for fi, _ in members for s in factors[fi].jordan_sizes)
    mod_sq = modulus_squared(factors[fi0], ri0)
    head_factor = factors[fi0]

    def ball(prec: int) -> arb:
        z = head_factor.root_ball(ri0, prec)
        squared_modulus: arb = (z * z.conjugate()).real
        return squared_modulus

    block_notes = list(notes)
    if mod_sq is None:
        block_notes.append(
            "|alpha|^2 is not made an exact algebraic number at this degree; comparisons use certified enclosures"
        )

    def phase_of(oracle: RankOracle | None) -> PhaseBlock:
        return PhaseBlock(
            base_period=N0, exponents=tuple(exponents), c_hat=c_hat, row_groups=row_groups, exact_rank=oracle
        )

    orders = [relation[(head, m)] if m != head else (1, 0) for m in members]
    N0 = reduce(math.lcm, (m for m, _ in orders), 1)
    member_exp = [k * (N0 // m) % N0 for m, k in orders]

    Cq = to_fmpq_mat(C)
    p = len(C)
    columns = {} if columns is None else columns
    columns_num: list[np.ndarray] = []
    exponents: list[int] = []
    exact_cols: list[tuple[Root, list[list[Fraction]]]] = []
    for (fi, ri), e in zip(members, member_exp):
        f = factors[fi]
        if fi not in columns:  # C times the eigenvector polynomials: one product per factor, shared by its roots
            columns[fi] = _output_columns(Cq, f, p)
        with precision(START_PREC):
            theta = f.root_ball(ri)
            for coeffs in columns[fi]:
                exact_cols.append(((fi, ri), coeffs))
                vals = [horner(cs, theta) for cs in coeffs]
                nrm = sum((abs(v) ** 2 for v in vals), arb(0)).sqrt()
                if nrm > 0:
                    vals = [v / nrm for v in vals]
                columns_num.append(np.array([complex(to_float(v.real), to_float(v.imag)) for v in vals]))
                exponents.append(e)
    c_hat = np.column_stack(columns_num) if columns_num else np.zeros((p, 0), dtype=complex)

    if len(members) == 1:
        only = factors[fi0]
        oracle: RankOracle | None = _SingleRows(only, [c for _, c in exact_cols], row_groups)
        return _block(members, texts, values, sizes, mod_sq, ball, phase_of(oracle), certified, block_notes)

    oracle = _cyclotomic_oracle(members, factors, mod_sq, exact_cols, row_groups, N0)
    if oracle is not None:
        return _block(members, texts, values, sizes, mod_sq, ball, phase_of(oracle), certified, block_notes)
    try:
        K, member_vals = _member_field_and_values(members, factors, mod_sq)
    except (
        BasePolynomialError,
        ArithmeticError,
        NotImplementedError,
        ValueError,
    ):  # SymPy could not build or embed in the compositum
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
    return _block(members, texts, values, sizes, mod_sq, ball, phase_of(oracle), certified, block_notes)


def _block(
    members: Sequence[Root],
    texts: tuple[str, ...],
    values: tuple[complex, ...],
    sizes: tuple[int, ...],
    mod_sq: AlgebraicReal | None,
    ball: Callable[[int], arb],
    phase: PhaseBlock,
    certified: bool,
    notes: Sequence[str],
) -> FmoBlock:
    with precision(START_PREC):
        mod_sq_float = to_float(ball(START_PREC))
    return FmoBlock(
        members=tuple(members),
        eigenvalue_texts=texts,
        eigenvalue_values=values,
        jordan_sizes=sizes,
        modulus_sq=mod_sq,
        modulus_sq_float=mod_sq_float,
        phase=phase,
        certified=certified,
        notes=tuple(notes),
        modulus_sq_ball=ball,
    )


def fmo_blocks(system: System, budget: Budget | None = None) -> list[FmoBlock]:
    """All FMO blocks of ``system``, largest modulus first; the zero class last.

    Examples
    --------
    >>> from fractions import Fraction as F
    >>> from kfio.model import SystemRecord as System
    >>> s = System(A=((F(2), F(0)), (F(0), F(-2))), C=((F(1), F(1)),))
    >>> [(b.eigenvalue_texts, b.phase.base_period) for b in fmo_blocks(s)]
    [(('2', '-2'), 2)]
    """
    factors = eigen_factors(system.A, budget)
    if system.sensors is None:
        groups: tuple[tuple[int, ...], ...] = (tuple(range(system.p)),)
    else:
        groups = tuple(s.rows for s in system.sensors)
    classes, relation, certified, notes = fmo_classes(factors, budget)
    blocks = []
    columns: dict[int, list[list[list[Fraction]]]] = {}
    for c in classes:
        if budget is not None:
            budget.tick("FMO blocks", 64)
        blocks.append(build_block(c, relation, factors, system.C, groups, certified, notes, columns))
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
