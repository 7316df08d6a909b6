"""The integer route to the pattern weights' floats gives the floats of the exact weights, bit for bit."""

from __future__ import annotations

import random
from fractions import Fraction

from kfio.riccati_bounds._riccati import float_pattern_weights, pattern_weights


def _old(lambdas):
    return [float(w) for w in pattern_weights([Fraction(x) for x in lambdas])]


def test_float_weights_match_the_fraction_route_bit_for_bit():
    rng = random.Random(7)
    for _ in range(2000):
        m = rng.randint(1, 4)
        lambdas = []
        for _ in range(m):
            kind = rng.randrange(4)
            if kind == 0:
                lambdas.append(rng.random())
            elif kind == 1:
                lambdas.append(Fraction(rng.randint(0, 10**12), 10**12))
            elif kind == 2:
                lambdas.append(Fraction(rng.randint(0, 97), 97))
            else:
                lambdas.append(rng.choice([0, 1, 0.0, 1.0, 0.5, Fraction(1, 3)]))
        new, old = float_pattern_weights(lambdas), _old(lambdas)
        assert [w.hex() for w in new] == [w.hex() for w in old], lambdas


def test_float_weights_on_bisection_points():
    # the slide's points: floats of a bisection between two grid fractions, other packets fixed
    lo, hi = Fraction(123456789, 10**12), Fraction(1)
    a, b = float(lo), float(hi)
    other = Fraction(7, 10)
    while b - a > 1e-13:
        c = 0.5 * (a + b)
        for lambdas in ([c], [Fraction(c), other], [other, c]):
            assert float_pattern_weights(lambdas) == _old(lambdas)
        a, b = (a, c) if c > 0.3 else (c, b)


def test_congruence_matrix_and_residual_unchanged_bit_for_bit():
    """The cached gathers give the old ``T``; the unscaled residual is the scaled one's ``M``."""
    import numpy as np

    from kfio.riccati_bounds._certificate import _float_residual
    from kfio.riccati_bounds._riccati import ArrivalModel
    from kfio.riccati_bounds._vech import congruence_matrix, vech_layout

    rng = np.random.default_rng(7)
    for n in (1, 2, 3, 4, 5, 6, 8, 9):
        iu, ju, _ = vech_layout(n)
        for _ in range(10):
            M = rng.standard_normal((n, n))
            P, Q = M[iu], M[ju]
            W = (P[:, :, None] * Q[:, None, :]).reshape(len(iu), n * n)
            old = W[:, iu * n + ju]
            old += W[:, ju * n + iu]
            old[:, iu == ju] *= 0.5
            assert np.array_equal(congruence_matrix(M), old)
            assert np.array_equal(congruence_matrix(M.T), congruence_matrix(M.T.copy()))
            C = (rng.standard_normal((1, n)),)
            K = (rng.standard_normal((n, 1)),)
            model = ArrivalModel(M, np.zeros((n, n)), C, (np.zeros((1, 1)),), (0.3, 0.7))
            B = rng.standard_normal((n, n))
            X = B @ B.T
            full, scale = _float_residual(model, K, X)
            bare, nan = _float_residual(model, K, X, scaled=False)
            assert np.array_equal(full, bare) and scale > 0 and nan != nan
