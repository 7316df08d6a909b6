"""The previous FMO route, kept as a test oracle: 60-digit ratios checked by an exact resultant test.

``Res_y(f(y), g(x y))`` vanishes at ``x = v / u`` for every pair of roots ``u`` of ``f`` and ``v`` of
``g``; its cyclotomic factors give the roots of unity among the ratios exactly, when
``deg f * deg g <= MAX_RESULTANT_DEGREE``.  The library decides the same classes from certified
enclosures (:func:`kfio.structure.fmo_classes`); ``tests/structure/test_certified.py`` compares the
two.  Moved here from ``kfio.structure._fmo``: the library does not ship test oracles.
"""

from __future__ import annotations

from typing import Sequence

import mpmath
from sympy import QQ, Poly, resultant, symbols

from kfio._budget import Budget
from kfio.errors import NumericalFailure
from kfio.structure._eigen import DIGITS, EigenFactor, X
from kfio.structure._fmo import Root, _order_of_ratio, _UnionFind
from kfio.structure._unity import euler_phi

_Y = symbols("y")


#: Largest ``deg f * deg g`` for which the resultant test is run exactly.
MAX_RESULTANT_DEGREE = 144


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
        if euler_phi(m) == d and Poly(cyclotomic_poly(m, X), X, domain=QQ) == h.monic():
            return m
    raise NumericalFailure("cyclotomic factor of unknown order")  # pragma: no cover


def fmo_classes_resultant(
    factors: Sequence[EigenFactor], budget: Budget | None = None
) -> tuple[list[list[Root]], dict[tuple[Root, Root], tuple[int, int]], bool, list[str]]:
    """The previous route, kept as a test oracle: 60-digit ratios checked by the resultant test.

    Returns the classes, the relation ``(u, v) -> (m, k)`` meaning
    ``v / u = exp(2 pi i k / m)``, whether every relation (and non-relation)
    was certified by the resultant test (only when ``deg f * deg g <=``
    :data:`MAX_RESULTANT_DEGREE`), and notes.
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
