"""Certified structure (flint enclosures, adjugate eigenvectors, proved FMO relations) against the exact routes.

Oracles: the number-field null space (``eigen_factors(route="nullspace")``),
the resultant test of the previous FMO route (``fmo_classes_resultant``,
exact for ``deg f * deg g <= 144``), substitution back into ``A v = theta v``
over ``Q(theta)``, and hand-built block structures.
"""

from __future__ import annotations

import cmath
import json
import random
from fractions import Fraction as F

import numpy as np
import pytest
import sympy
from flint import fmpz_poly

from kfio import load_request
from kfio.model._types import System
from kfio.stability._verdict import analyze
from kfio.structure._eigen import eigen_factors
from kfio.structure._fmo import fmo_blocks, fmo_classes

from support.fmo_resultant import fmo_classes_resultant


def fr(M):
    return tuple(tuple(F(x) for x in row) for row in M)


def similar(A, seed):
    """``T A T^-1`` for a random unimodular integer ``T`` (exact)."""
    rng = random.Random(seed)
    n = len(A)
    T = sympy.eye(n)
    for _ in range(2 * n if n > 1 else 0):
        i, j = rng.sample(range(n), 2)
        E = sympy.eye(n)
        E[i, j] = rng.choice([-1, 1, 2])
        T = T * E
    B = T * sympy.Matrix([[sympy.Rational(x.numerator, x.denominator) for x in row] for row in A]) * T.inv()
    return tuple(tuple(F(int(x.p), int(x.q)) for x in B.row(i)) for i in range(n))


def companion(coeffs_low_first):
    """Companion matrix of the monic polynomial with the given rational coefficients."""
    d = len(coeffs_low_first) - 1
    A = [[F(0)] * d for _ in range(d)]
    for i in range(1, d):
        A[i][i - 1] = F(1)
    for i in range(d):
        A[i][d - 1] = -F(coeffs_low_first[i]) / F(coeffs_low_first[d])
    return A


def scaled_cyclotomic(m, alpha):
    """Companion of ``prod (x - alpha zeta)`` over primitive ``m``-th roots ``zeta``."""
    c = [int(x) for x in fmpz_poly.cyclotomic(m).coeffs()]
    d = len(c) - 1
    return companion([F(c[i]) * alpha ** (d - i) for i in range(d + 1)])


def block_diag(*blocks):
    n = sum(len(b) for b in blocks)
    A = [[F(0)] * n for _ in range(n)]
    k = 0
    for b in blocks:
        for i, row in enumerate(b):
            for j, x in enumerate(row):
                A[k + i][k + j] = F(x)
        k += len(b)
    return A


def class_signature(classes, relation, factors):
    """Classes as sets of numerical eigenvalues (rounded), with their orders: comparable across routes."""
    out = set()
    for c in classes:
        head = c[0]
        vals = frozenset(
            (
                complex(round(complex(factors[fi].roots[ri]).real, 9), round(complex(factors[fi].roots[ri]).imag, 9)),
                relation[(head, (fi, ri))][0] if (fi, ri) != head else 1,
            )
            for fi, ri in c
        )
        out.add(vals)
    return out


def check_substitution(A, f):
    """``A v(theta) = theta v(theta)`` exactly in ``Q[theta]/(f)`` for every basis vector."""
    x = sympy.symbols("x")
    fp = sympy.Poly(f.poly.as_expr(), x, domain="QQ")
    Ad = sympy.Matrix([[sympy.Rational(a.numerator, a.denominator) for a in row] for row in A])
    for vec in f.eigvec_coeffs:
        v = [
            sympy.Poly(list(reversed([sympy.Rational(c.numerator, c.denominator) for c in cs])), x, domain="QQ")
            for cs in vec
        ]
        for i in range(len(A)):
            lhs = sum((v[j] * Ad[i, j] for j in range(len(A))), sympy.Poly(0, x, domain="QQ"))
            rhs = v[i] * sympy.Poly(x, x, domain="QQ")
            assert (lhs - rhs).rem(fp).is_zero


def random_matrix(rng, n, lo=-3, hi=3):
    return tuple(tuple(F(rng.randint(lo, hi)) for _ in range(n)) for _ in range(n))


def random_structured(rng, seed):
    """Random block-diagonal matrices with shared moduli, roots of unity and repeated eigenvalues, hidden by similarity."""
    pieces = []
    for _ in range(rng.randint(1, 3)):
        kind = rng.choice(["rot", "scalar", "jordan", "cyc", "rand"])
        if kind == "rot":
            pieces.append([[0, -2], [2, 0]] if rng.random() < 0.5 else [[-1, -3], [1, -1]])
        elif kind == "scalar":
            pieces.append([[rng.choice([2, -2, F(5, 4)])]])
        elif kind == "jordan":
            lam = rng.choice([2, -1, F(3, 2)])
            s = rng.randint(2, 3)
            pieces.append([[lam if i == j else (1 if j == i + 1 else 0) for j in range(s)] for i in range(s)])
        elif kind == "cyc":
            pieces.append(scaled_cyclotomic(rng.choice([3, 4, 5, 8]), F(rng.choice([1, 2, 3]), 2)))
        else:
            pieces.append([[rng.randint(-3, 3) for _ in range(2)] for _ in range(2)])
    return similar(block_diag(*pieces), seed)


def agree(A):
    factors = eigen_factors(A)
    fast = fmo_classes(factors)
    slow = fmo_classes_resultant(factors)
    assert fast[2], fast[3]
    assert class_signature(fast[0], fast[1], factors) == class_signature(slow[0], slow[1], factors)
    return factors, fast


@pytest.mark.parametrize("seed", range(60))
def test_fmo_classes_agree_with_resultant_route_random(seed):
    rng = random.Random(seed)
    A = random_matrix(rng, rng.randint(2, 6))
    agree(A)


@pytest.mark.parametrize("seed", range(40))
def test_fmo_classes_agree_with_resultant_route_structured(seed):
    rng = random.Random(1000 + seed)
    agree(random_structured(rng, seed))


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(200))
def test_fmo_classes_agree_many(seed):
    rng = random.Random(5000 + seed)
    agree(random_structured(rng, seed) if seed % 2 else random_matrix(rng, rng.randint(3, 8)))


@pytest.mark.parametrize("seed", range(30))
def test_adjugate_eigenvectors_match_the_number_field_route(seed):
    rng = random.Random(seed)
    n = rng.randint(2, 7)
    A = random_matrix(rng, n)
    fast = eigen_factors(A)
    slow = eigen_factors(A, route="nullspace")
    assert [(f.poly, f.jordan_sizes) for f in fast] == [(f.poly, f.jordan_sizes) for f in slow]
    for f, g in zip(fast, slow):
        if f.multiplicity == 1:
            assert f.route == "adjugate"
            check_substitution(A, f)
        for i in range(f.degree):
            v = np.array([complex(x) for x in f.eigvec_values(i)[0]])
            w = np.array([complex(x) for x in g.eigvec_values(i)[0]])
            # the same line: |<v, w>| = |v| |w|
            assert abs(abs(np.vdot(v, w)) - np.linalg.norm(v) * np.linalg.norm(w)) <= 1e-9 * np.linalg.norm(
                v
            ) * np.linalg.norm(w)


def test_dense_40_is_certified_and_eigenvectors_substitute_back():
    rng = random.Random(40)
    A = random_matrix(rng, 40)
    (f,) = eigen_factors(A)
    assert f.degree == 40 and f.route == "adjugate"
    An = np.array([[float(x) for x in r] for r in A])
    for i in (0, 17, 39):
        v = np.array([complex(x) for x in f.eigvec_values(i)[0]])
        assert np.linalg.norm(An @ v - complex(f.roots[i]) * v) <= 1e-9 * np.linalg.norm(v)
    bl = fmo_blocks(System(A=A, C=((F(1),) + (F(0),) * 39,)))
    assert len(bl) == 40 and all(b.certified for b in bl)


def rationalized_rotation(turns, digits=30):
    """2x2 rotation by ``2 pi turns`` with entries rounded to ``digits`` decimals (rational)."""
    z = cmath.exp(2j * cmath.pi * turns)
    with_digits = sympy.N(sympy.exp(2 * sympy.pi * sympy.I * sympy.Rational(str(turns))), digits + 5)
    c = F(str(sympy.re(with_digits).round(digits)))
    s = F(str(sympy.im(with_digits).round(digits)))
    assert abs(complex(float(c), float(s)) - z) < 1e-12
    return [[c, -s], [s, c]]


def test_ratio_near_a_root_of_unity_is_not_related():
    # eigenvalues c +- i s with arg = 2 pi (1/7 + 1e-12): the ratio is within 1e-11 of exp(4 pi i / 7)
    A = fr(block_diag(rationalized_rotation(1 / 7 + 1e-12), [[1]]))
    factors, (classes, relation, certified, _) = agree(A)
    assert certified and len(classes) == 3


def test_exact_root_of_unity_ratio_is_related():
    # 5/4 times a primitive 7th root of unity and its conjugates, hidden by a similarity: one class, period 7
    A = similar(scaled_cyclotomic(7, F(5, 4)), seed=7)
    (b,) = fmo_blocks(System(A=A, C=((F(1),) + (F(0),) * 5,)))
    assert b.phase.base_period == 7 and b.certified and b.modulus_sq.rational == F(25, 16)
    agree(A)


@pytest.mark.parametrize("m", [13, 15, 21])
def test_high_degree_cyclotomic_times_alpha(m):
    # degree 12 / 8 / 12: beyond the exterior-square degree, |alpha|^2 proved rational by reciprocity
    A = similar(scaled_cyclotomic(m, F(3, 2)), seed=m)
    d = len(A)
    (b,) = fmo_blocks(System(A=A, C=((F(1),) + (F(0),) * (d - 1),)))
    assert b.phase.base_period == m and b.certified and b.modulus_sq.rational == F(9, 4)
    assert b.phase.exact_rank is not None


def test_equal_moduli_without_relation():
    # 5/4 and (3 +- 4i)/4: all of modulus 5/4, (3 + 4i)/5 is not a root of unity
    A = similar(block_diag([[F(5, 4)]], [[F(3, 4), -1], [1, F(3, 4)]]), seed=3)
    factors, (classes, _, certified, _) = agree(A)
    assert certified and len(classes) == 3
    bl = fmo_blocks(System(A=A, C=((F(1), F(1), F(1)),)))
    assert all(b.modulus_sq.rational == F(25, 16) and b.certified for b in bl)


@pytest.mark.parametrize("blocks", [[(2, 2), (-2, 1)], [(F(3, 2), 3), (F(-3, 2), 2)], [(2, 2), (2, 2), (-1, 1)]])
def test_jordan_blocks_and_repeated_factors(blocks):
    pieces = [[[lam if i == j else (1 if j == i + 1 else 0) for j in range(s)] for i in range(s)] for lam, s in blocks]
    A = similar(block_diag(*pieces), seed=len(blocks))
    factors, _ = agree(A)
    for f in factors:
        assert f.route == ("adjugate" if f.multiplicity == 1 else "nullspace")
        check_substitution(A, f)


def test_repeated_complex_factor():
    R = [[0, -2], [2, 0]]
    A = similar(block_diag(R, R, [[2]]), seed=11)
    factors, (classes, _, _, _) = agree(A)
    assert len(classes) == 1
    (f,) = [f for f in factors if f.degree == 2]
    assert f.multiplicity == 2 and f.jordan_sizes == (1, 1) and f.route == "nullspace"


def test_issue12_item4_huge_diagonal_rotation():
    """``A = [[1e20, -1], [1, 1e20]]``: mpmath's root finder did not converge (HTTP 500)."""
    req = load_request(
        json.dumps(
            {
                "system": {"A": [["1e20", -1], [1, "1e20"]], "C": [[1, 0]]},
                "channel": {"model": "bernoulli", "arrival_probability": "1/2"},
            }
        )
    )
    r = analyze(req)
    assert r.verdict == "unstable" and len(r.blocks) == 2 and all(b.certified for b in r.blocks)
    assert {b.modulus_exact for b in r.blocks} == {f"sqrt({10**40 + 1})"}


def test_issue12_item5_200_digit_entries():
    """A 22 x 22 matrix with 200-digit entries: the factor sort key stringified 4400-digit coefficients."""
    rng = random.Random(5)
    n = 22
    A = tuple(tuple(F(rng.randint(-(10**200), 10**200)) for _ in range(n)) for _ in range(n))
    bl = fmo_blocks(System(A=A, C=((F(1),) + (F(0),) * (n - 1),)))
    assert len(bl) == 22 and all(b.certified for b in bl)
    assert all(b.compare_power(1, F(1)) == (1, True) for b in bl)
    An = np.array([[float(x) for x in r] for r in A])
    ev = np.linalg.eigvals(An / 1e200)
    got = [complex(v) / 1e200 for b in bl for v in b.eigenvalue_values]
    assert max(min(abs(ev - z)) for z in got) < 1e-6 * max(abs(ev))


def test_stable_block_certified_from_an_enclosure():
    # |alpha| < 1 for a degree-12 non-real factor (no exact |theta|^2): proved from the enclosure
    rng = random.Random(12)
    while True:
        A = tuple(tuple(F(rng.randint(-3, 3), 8) for _ in range(12)) for _ in range(12))
        fs = eigen_factors(A)
        if len(fs) == 1 and fs[0].n_real < 12:
            break
    req = load_request(
        json.dumps(
            {
                "system": {"A": [[f"{x.numerator}/{x.denominator}" for x in row] for row in A], "C": [[1] + [0] * 11]},
                "channel": {"model": "bernoulli", "arrival_probability": "1/2"},
            }
        )
    )
    r = analyze(req)
    for b in r.blocks:
        assert b.certified
        if b.rate is None:
            assert b.modulus < 1


def test_budget_is_checked_inside_the_eigenstructure_steps():
    """The eigenstructure steps check the budget (counted in steps, not seconds)."""
    from kfio._budget import Budget
    from kfio.errors import BudgetExceeded

    rng = random.Random(40)
    A = random_matrix(rng, 40)
    system = System(A=A, C=((F(1),) + (F(0),) * 39,))
    with pytest.raises(BudgetExceeded, match="eigenstructure"):
        fmo_blocks(system, Budget(max_steps=100))
    spent = Budget()
    fmo_blocks(system, spent)
    assert spent.steps > 100  # the whole computation checks in many times
    with pytest.raises(BudgetExceeded):
        fmo_blocks(system, Budget(max_steps=spent.steps - 1))


@pytest.mark.parametrize("p,q", [("1/10", "3/10"), ("1/2", "1/2"), ("9/10", "1/20")])
def test_markov_rate_with_irrational_modulus_is_certified(p, q):
    """Gilbert-Elliott channel, ``|alpha|^2`` irrational: enclosures of ``beta`` and of the Perron root decide ``rate`` vs 1."""
    req = load_request(
        json.dumps(
            {
                "system": {"A": [[1, 1], [1, 0]], "C": [[1, 0]]},
                "channel": {"model": "gilbert_elliott", "failure_rate": p, "recovery_rate": q},
            }
        )
    )
    r = analyze(req)
    (b,) = [b for b in r.blocks if b.rate is not None]
    assert b.certified and b.modulus_exact is not None
    # the golden ratio: rate = phi^2 sigma, compared with 1 in floats far from the boundary
    phi2 = ((1 + 5**0.5) / 2) ** 2
    assert abs(b.rate - phi2 * b.sigma) < 1e-9 and abs(b.rate - 1) > 1e-6
    assert b.verdict == ("unstable" if b.rate > 1 else "stable")


def test_single_eigenvalue_class_with_two_chains_has_exact_ranks():
    # 1 +- 2i twice: each root is its own class (the conjugate ratio is not a root of unity), L = 2
    R = [[1, -2], [2, 1]]
    A = similar(block_diag(R, R), seed=4)
    two = fmo_blocks(System(A=A, C=((F(1), F(0), F(0), F(0)), (F(0), F(1), F(2), F(0)))))
    one = fmo_blocks(System(A=A, C=((F(1), F(0), F(0), F(0)),)))
    for blocks, rank in ((two, 2), (one, 1)):
        assert len(blocks) == 2
        for b in blocks:
            assert b.phase.n_columns == 2 and b.modulus_sq.rational == 5
            assert b.phase.exact_rank([(0, 0)]) == rank == b.phase.numeric_rank([(0, 0)])
