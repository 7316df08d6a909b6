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
