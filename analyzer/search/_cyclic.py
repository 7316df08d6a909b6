"""An upper bound on the largest blind set of one row, from the cyclic code of its exponents.

With one row per phase, ``r_n = c diag(omega^n)`` and ``omega_j = zeta^{e_j}``
(``zeta = exp(2 pi i / N0)``).  When every ``c_j`` is non-zero and the
exponents ``E = {e_j}`` are distinct, a set ``F`` of phases is blind iff some
``v != 0`` has ``sum_j v_j c_j zeta^{e_j n} = 0`` for every ``n`` in ``F``: iff
``F`` lies in the zero set of a non-zero word of the code
``C(E) = span{n -> zeta^{e n} : e in E}`` of length ``N0`` (the cyclic code
with non-zeros ``E``; the blind sets of ``sigma_k`` in docs/sigma.md).  So the largest blind
set has ``N0 - d(E)`` phases, ``d`` the code's minimum distance.

**Product bound.**  For ``N0 = q r`` with ``gcd(q, r) = 1`` the Chinese
remainder theorem identifies ``Z_N0`` with ``Z_q x Z_r``, and the character
``n -> zeta^{e n}`` with a product of a character of ``Z_q`` (exponent
``e r' mod q``, ``r' = r^{-1} mod q``) and one of ``Z_r``.  So ``C(E)`` lies in
the tensor product of the codes of the projections of ``E``, whose minimum
distance is the product of theirs (the product-code theorem, MacWilliams and
Sloane (1977), chapter 18, section 2; it holds over any field).  Multiplying the
exponents of a component by the unit ``r'`` permutes its coordinates, which
keeps weights, so ``d(E) >= prod_q d(E mod q)`` over the prime powers ``q || N0``.
Each factor is the largest blind set of a block of at most ``q`` phases,
found by the one-group branch and bound.  The bound is exact when ``E`` is
the full product of its projections, as for the primitive ``N``-th roots of
unity (the companion of ``a zeta_N``): there every factor is ``2``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .._budget import Budget
from ._blind import Margins, Objective, SlotSpace, search


def _prime_powers(n: int) -> list[int]:
    """The prime powers ``q`` with ``q || n``, ascending."""
    out, p = [], 2
    while p * p <= n:
        if n % p == 0:
            q = 1
            while n % p == 0:
                n //= p
                q *= p
            out.append(q)
        p += 1
    if n > 1:
        out.append(n)
    return sorted(out)


def _component_distance(q: int, residues: Sequence[int], budget: Budget) -> int:
    """``d`` of the code on ``Z_q`` spanned by the characters ``n -> exp(2 pi i s n / q)``, ``s`` in ``residues``."""
    S = sorted(set(residues))
    if len(S) == q:
        return 1  # every character: the whole space
    n = np.arange(q)
    rows = np.exp(2j * np.pi * np.outer(n, S) / q)[:, None, :]
    space = SlotSpace(n_phases=q, n_groups=1, rows=rows, tol=1e-9 * max(1.0, float(np.sqrt(len(S)))))
    objective = Objective(score=_count, max_weight=lambda best: q - int(best) - 1)
    best = search(space, budget, Margins(space.tol), objective).maximal[0]
    return q - int(best.sum())


def _count(masks: np.ndarray) -> np.ndarray:
    result: np.ndarray = masks.sum(axis=1).astype(float)
    return result


def largest_blind_bound(n_phases: int, exponents: Sequence[int], budget: Budget) -> int | None:
    """At least the size of every blind set of one row ``c diag(omega^n)`` with no zero ``c_j`` (module docstring).

    ``N0 - prod_q d(E mod q)`` over the prime powers ``q || N0``; ``None``
    when it could not be smaller than a search finds on its own (``N0`` a
    prime power, or repeated exponents, where every set of one phase short
    of full is blind anyway).

    Examples
    --------
    The 12 primitive 21st roots of unity (exponents prime to 21): ``d = 2 * 2``.

    >>> largest_blind_bound(21, [e for e in range(21) if math.gcd(e, 21) == 1], Budget(max_steps=1000))
    17
    """
    parts = _prime_powers(n_phases)
    if len(parts) < 2 or len(set(e % n_phases for e in exponents)) < len(exponents):
        return None
    d = math.prod(_component_distance(q, [e % q for e in exponents], budget) for q in parts)
    return n_phases - d
