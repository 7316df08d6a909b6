"""The factors of ``theta^m``'s polynomial from the minimal polynomial of ``C_f^m``, against the characteristic polynomial's."""

from __future__ import annotations

import random

import pytest
from flint import fmpq, fmpq_mat, fmpz_poly

from kfio.structure._unity import _power_factors


def _charpoly_factors(coeffs: tuple[int, ...], m: int) -> set[tuple[int, ...]]:
    """The previous route: every irreducible factor of ``charpoly(C_f^m)``."""
    d = len(coeffs) - 1
    M = fmpq_mat(d, d)
    for i in range(1, d):
        M[i, i - 1] = 1
    for i in range(d):
        M[i, d - 1] = fmpq(-coeffs[i], coeffs[-1])
    _, factors = (M**m).charpoly().numer().factor()
    return {tuple(int(c) for c in h.coeffs()) for h, _ in factors}


@pytest.mark.parametrize("seed", range(12))
def test_power_factors_are_the_charpoly_factors(seed: int) -> None:
    rng = random.Random(seed)
    if seed % 3 == 0:  # a scaled cyclotomic polynomial: theta^m of low degree, high multiplicity
        n = rng.choice([7, 9, 12, 15, 20])
        a = rng.choice([2, 3])
        c = [int(x) for x in fmpz_poly.cyclotomic(n).coeffs()]
        coeffs = tuple(ci * a ** (len(c) - 1 - i) for i, ci in enumerate(c))
        ms = [2, 3, n // 2 or 1, n, 2 * n]
    else:  # random, sometimes reducible (a product of two)
        f = fmpz_poly([rng.randint(-4, 4) for _ in range(rng.randint(2, 6))] + [rng.randint(1, 3)])
        if seed % 3 == 1:
            f *= fmpz_poly([rng.randint(-3, 3) or 1, rng.randint(-2, 2), 1])
        coeffs = tuple(int(x) for x in f.coeffs())
        if coeffs[0] == 0:
            coeffs = (1,) + coeffs[1:]
        ms = [1, 2, 3, 6]
    for m in ms:
        got = _power_factors(coeffs, m)
        assert len(set(got)) == len(got)
        assert set(got) == _charpoly_factors(coeffs, m)
