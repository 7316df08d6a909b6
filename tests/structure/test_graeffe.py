"""``|theta|^2`` of a real root from the Graeffe transform, against SymPy's minimal polynomial of ``theta^2``."""

from __future__ import annotations

import random

import pytest
import sympy
from flint import fmpq_poly, fmpz_poly
from sympy import QQ, CRootOf, Poly

from kfio.structure._eigen import X
from kfio.structure._modulus import _companion, _graeffe_factors


def _charpoly_of_square(coeffs):
    """The old route: ``charpoly(C_f^2)`` of the monic companion matrix (roots ``theta_i^2``)."""
    C = _companion(coeffs)
    return (C * C).charpoly()


CASES = [
    (-2, 0, 1),  # x^2 - 2: theta^2 = 2, g = (x - 2)^2
    (-2, 0, 0, 0, 1),  # x^4 - 2: theta^2 = sqrt(2), g = (x^2 - 2)^2
    (-1, -3, 0, 1),  # x^3 - 3x - 1
    (3, -7, 0, 5),  # non-monic
    (-5, 0, 3),  # 3x^2 - 5: theta^2 = 5/3
]


def _random_irreducible(rng: random.Random):
    while True:
        d = rng.randint(2, 7)
        c = [rng.randint(-9, 9) for _ in range(d)] + [rng.choice([1, 1, 2, 3, 7])]
        if rng.random() < 0.2:  # an even polynomial h(x^2): theta^2 has half the degree
            c = [c[i // 2] if i % 2 == 0 else 0 for i in range(2 * d - 1)]
            if c[-1] == 0:
                continue
        f = fmpz_poly(c)
        _, fac = f.factor()
        if len(fac) == 1 and fac[0][1] == 1 and fac[0][0].degree() == len(c) - 1 and c[0] != 0:
            return tuple(c)


@pytest.mark.parametrize("seed", range(3))
def test_graeffe_factor_is_the_minimal_polynomial_of_theta_squared(seed: int) -> None:
    rng = random.Random(seed)
    cases = CASES + [_random_irreducible(rng) for _ in range(12)]
    for c in cases:
        (g,) = _graeffe_factors(c)
        G = fmpz_poly(list(g))
        _, fac = G.factor()
        assert len(fac) == 1 and fac[0][1] == 1, (c, g)  # irreducible
        f = Poly(list(reversed(c)), X, domain=QQ)
        for i in range(f.count_roots()):
            m = sympy.minimal_polynomial(CRootOf(f, i) ** 2, X, polys=True)
            assert m.monic() == Poly(list(reversed(g)), X, domain=QQ).monic(), (c, i)
        # the same roots as the old charpoly(C^2) route, which made f monic by y = a theta
        a, d = c[-1], len(c) - 1
        monic = tuple(c[i] * a ** (d - 1 - i) for i in range(d)) + (1,)
        P = _charpoly_of_square(monic)
        scaled = fmpz_poly([g[i] * (a * a) ** (len(g) - 1 - i) for i in range(len(g))])  # roots a^2 theta^2
        assert fmpq_poly(P) % fmpq_poly(scaled) == 0, c
