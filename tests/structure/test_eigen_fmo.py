"""Exact eigenstructure and FMO classes (Rohr, Marelli and Fu (2014), Definitions 3-5).

Independent routes: SymPy's ``Matrix.jordan_form`` on small matrices (fine at
this size), numpy eigenvalues, and hand-built block structures.
"""

from __future__ import annotations

import random
from fractions import Fraction as F

import numpy as np
import pytest
import sympy

from kfio.model._types import System
from kfio.structure._eigen import eigen_factors
from kfio.structure._fmo import fmo_blocks


def frac_matrix(M):
    return tuple(tuple(F(x) if not isinstance(x, str) else F(x) for x in row) for row in M)


def similar(J, seed):
    """``T J T^-1`` for a random unimodular integer ``T`` (exact)."""
    rng = random.Random(seed)
    n = J.shape[0]
    T = sympy.eye(n)
    for _ in range(3 * n):
        i, j = rng.sample(range(n), 2)
        k = rng.choice([-2, -1, 1, 2])
        E = sympy.eye(n)
        E[i, j] = k
        T = T * E
    A = T * sympy.Matrix(J) * T.inv()
    return [[F(int(x.p), int(x.q)) for x in A.row(i)] for i in range(n)], T


def jordan(blocks):
    """Block-diagonal Jordan matrix from (eigenvalue, size) pairs."""
    n = sum(s for _, s in blocks)
    J = sympy.zeros(n)
    k = 0
    for lam, s in blocks:
        for i in range(s):
            J[k + i, k + i] = lam
            if i + 1 < s:
                J[k + i, k + i + 1] = 1
        k += s
    return J


@pytest.mark.parametrize(
    "blocks",
    [
        [(2, 2), (2, 1), (-1, 3)],
        [(sympy.Rational(5, 4), 1), (sympy.Rational(11, 10), 1)],
        [(0, 2), (3, 1), (3, 1)],
        [(1, 4)],
    ],
)
def test_jordan_sizes_match_jordan_form(blocks):
    A, _ = similar(jordan(blocks), seed=len(blocks))
    got = {}
    for f in eigen_factors(frac_matrix(A)):
        got[str(f.rational_root)] = sorted(f.jordan_sizes)
    _, J = sympy.Matrix(A).jordan_form()
    want: dict[str, list[int]] = {}
    i = 0
    n = J.shape[0]
    while i < n:
        s = 1
        while i + s < n and J[i + s - 1, i + s] == 1:
            s += 1
        want.setdefault(str(J[i, i]), []).append(s)
        i += s
    assert got == {k: sorted(v) for k, v in want.items()}


def test_irreducible_quartic_jordan_and_eigvecs():
    A = frac_matrix([[0, 0, 0, -3], [1, 0, 0, 1], [0, 1, 0, 0], [0, 0, 1, 2]])  # companion of x^4-2x^3-x+3
    (f,) = eigen_factors(A)
    assert f.degree == 4 and f.jordan_sizes == (1,)
    An = np.array([[float(x) for x in r] for r in A])
    for i in range(4):
        v = np.array([complex(x) for x in f.eigvec_values(i)[0]])
        theta = complex(f.roots[i])
        assert np.linalg.norm(An @ v - theta * v) < 1e-12 * np.linalg.norm(v)


def blocks_of(A, C):
    return fmo_blocks(System(A=frac_matrix(A), C=frac_matrix(C)))


def test_seed001_example1_block():
    (b,) = blocks_of([[3, 0], [0, -3]], [[1, 1]])
    assert set(b.eigenvalue_texts) == {"3", "-3"} and b.modulus_sq.rational == 9
    assert b.phase.base_period == 2 and sorted(b.phase.exponents) == [0, 1]
    assert b.phase.exact_rank([(0, 0)]) == 1 and b.phase.exact_rank([(0, 0), (1, 0)]) == 2


def test_equal_modulus_without_root_of_unity_ratio_are_separate_classes():
    # eigenvalues 5 and 3 +- 4i: all of modulus 5, (3+4i)/5 is not a root of unity
    A = [[5, 0, 0], [0, 3, -4], [0, 4, 3]]
    bl = blocks_of(A, [[1, 1, 1]])
    assert len(bl) == 3 and all(b.phase.base_period == 1 for b in bl)
    assert all(b.modulus_sq.rational == 25 for b in bl) and all(b.certified for b in bl)


def test_rotation_blocks_share_a_class():
    # 2*R(90deg) (+-2i), 2*R(120deg), -2: all of modulus 2 with root-of-unity ratios
    R4 = [[0, -2], [2, 0]]
    R3 = [[-1, "-3"], [1, -1]]  # eigenvalues -1 +- i sqrt(3) = 2 exp(+-2 pi i/3)
    A = sympy.diag(sympy.Matrix(R4), sympy.Matrix([[-1, -3], [1, -1]]), sympy.Matrix([[-2]]))
    (b,) = blocks_of(A.tolist(), [[1, 0, 1, 0, 1]])
    assert len(b.members) == 5 and b.modulus_sq.rational == 4
    assert b.phase.base_period == 12
    del R3


def test_irrational_modulus_class():
    # eigenvalues +- sqrt(2): ratio -1, |alpha|^2 = 2
    (b,) = blocks_of([[0, 2], [1, 0]], [[1, 0]])
    assert b.modulus_sq.rational == 2 and b.phase.base_period == 2
    # eigenvalues (1 +- sqrt 5)/2: different moduli, two classes, |alpha|^2 irrational
    bl = blocks_of([[1, 1], [1, 0]], [[1, 0]])
    assert len(bl) == 2 and bl[0].modulus_sq.minpoly is not None
    assert abs(float(bl[0].modulus_sq) - ((1 + 5**0.5) / 2) ** 2) < 1e-12


def test_zero_eigenvalues_form_their_own_class():
    bl = blocks_of([[0, 1, 0], [0, 0, 0], [0, 0, 2]], [[1, 0, 1]])
    assert bl[-1].eigenvalue_texts == ("0",) and bl[-1].phase is None and bl[-1].jordan_sizes == (2,)
    assert bl[0].eigenvalue_texts == ("2",)


def test_unobservable_mode_gives_zero_column():
    (b,) = blocks_of([[2, 1, 0], [0, 2, 0], [0, 0, 2]], [[1, 0, 0]])
    assert b.jordan_sizes == (2, 1)
    assert b.phase.exact_rank([(0, 0)]) == 1 and b.phase.n_columns == 2


def test_complex_pair_with_root_of_unity_ratio_in_irreducible_quartic():
    # x^4 + 1 roots: primitive 8th roots of unity scaled by 3/2 -> one class, period 8... ratios of order 2 and 4
    s = sympy.Rational(3, 2)
    x = sympy.symbols("x")
    c = sympy.Poly(x**4 + s**4, x).all_coeffs()
    A = [[0, 0, 0, -c[4]], [1, 0, 0, -c[3]], [0, 1, 0, -c[2]], [0, 0, 1, -c[1]]]
    (b,) = blocks_of(A, [[1, 0, 0, 0]])
    assert len(b.members) == 4 and b.phase.base_period == 4 and b.modulus_sq.rational == F(9, 4)
    assert b.certified
