"""The loop's stationary average cost from the coupled Lyapunov equations (exact over Q).

When ``rho(T) < 1`` the mode-wise second moments converge to the unique
solution of ``Y_j = sum_i p_ij (M_i Y_i M_i' + pi_i G_i Sigma G_i')``
(Costa, Fragoso and Marques 2005, Ch. 3), and the average stage cost
``lim E[x' W x + a' U a]`` (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, with the applied
input ``a``) is

    J = sum_i [ tr(W Y_i^xx) + sum_b w_b ( tr(U F_b Y_i F_b') + pi_i tr(U E_b Sigma E_b') ) ]

with ``a = F_b z + E_b n`` in pattern ``b`` of mode ``i``.  Unbounded (no
value) when ``rho(T) >= 1``.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Sequence

import flint

from ._mjls import Mjls


def _trace(m: flint.fmpq_mat) -> flint.fmpq:
    t = flint.fmpq(0)
    for i in range(m.nrows()):
        t += m[i, i]
    return t


def stationary_cost(sys: Mjls, moments: Sequence[flint.fmpq_mat]) -> Fraction:
    """``J`` of the module docstring for the exact stationary moments ``Y_i``."""
    total = flint.fmpq(0)
    for i, (Y, branches) in enumerate(zip(moments, sys.branches)):
        total += _trace(sys.Wz * Y)
        if sys.U.nrows() == 0:
            continue
        pi = flint.fmpq(sys.pi[i].numerator, sys.pi[i].denominator)
        for br in branches:
            w = flint.fmpq(br.weight.numerator, br.weight.denominator)
            total += w * _trace(sys.U * br.Fa * Y * br.Fa.transpose())
            total += w * pi * _trace(sys.U * br.Ea * sys.Sigma * br.Ea.transpose())
    return Fraction(int(total.p), int(total.q))


__all__ = ["stationary_cost"]
