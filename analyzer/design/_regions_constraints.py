"""Blind-pattern constraints of the exact partial-loss region (an *extension* of Rohr, Marelli and Fu (2014)).

Rohr, Marelli and Fu (2014), Theorem 1 decides stability for one packet.  docs/theory.md
("Beyond the seeds: exact partial-loss regions") carries its construction over
to ``m`` packets lost separately: for FMO block ``k`` with
``beta_k = |alpha_k|^2`` and period ``N_k``, a set ``F`` of (phase, sensor)
slots is blind when the stacked rows ``C_hat_{s,k} diag(omega^n)``,
``(n, s)`` in ``F``, lack full column rank, and

.. math::

    \\text{rate}_k^{N_k} = \\beta_k^{N_k} \\max_{F \\text{ maximal blind}}
        \\prod_s (1 - \\lambda_s)^{z_s(F)},

with ``z_s(F)`` the phases in ``[0, N_k)`` at which sensor ``s`` is *not* in
``F``.  This is the Bernoulli case of :func:`kfio.sigma._sigma.compute_sigma`
(the ``rho(P_F) = prod_s (1 - lambda_s)^{z_s}`` of its Kronecker structure;
Rohr, Marelli and Fu (2014), Corollary 2 for one packet).  It is **not** a theorem of the seeds:
Liu and Goldsmith (2004) only brackets the region between two bounds.

In the coordinates ``u_s = -log(1 - lambda_s) >= 0`` each pair ``(k, F)`` is a
half-space: block ``k`` is stable iff for every ``F``

.. math::

    \\sum_s z_s(F)\\, u_s > N_k \\log \\beta_k ,

so the exact stable region is an intersection of half-spaces (convex in
``u``).  A pattern whose ``z`` vector is componentwise ``>=`` another's never
binds (``(1 - lambda)^z`` is smaller for every ``lambda``); only the
componentwise-minimal ``z`` vectors are kept.

This module builds those constraints from the FMO blocks
(:func:`kfio.structure._fmo.fmo_blocks`) and the maximal blind sets that
:func:`kfio.sigma._sigma.compute_sigma` enumerates, and evaluates them exactly.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Sequence

import mpmath
import sympy

from .._budget import Budget
from ..errors import InvalidInput, NumericalFailure
from ..model import MarkovChannel
from ..model import SystemRecord as System
from ..sigma import SigmaResult, compare_rate_bernoulli, compute_sigma
from ..structure import DIGITS, AlgebraicReal, FmoBlock, fmo_blocks

#: Two values whose logs differ by more than this are ordered numerically
#: (the error at :data:`DIGITS` digits is below ``1e-55``); closer values are
#: compared in exact arithmetic.
SEPARATION = mpmath.mpf(10) ** -40

# compute_sigma needs a channel to run; the blind structure does not depend on
# it (only the scores do), and every maximal blind set is enumerated when there
# are several sensors.  For one sensor the largest blind set is what is found,
# which is the only one that matters for Bernoulli (Rohr, Marelli and Fu (2014), Corollary 2).
_PROBE = MarkovChannel("bernoulli", 0, (Fraction(1, 2),), {"arrival_probability": Fraction(1, 2)})


@dataclass(frozen=True)
class BlindPattern:
    """One maximal blind set (a representative of its shift orbit) and its miss counts.

    Attributes
    ----------
    slots:
        ``(phase, sensor)`` pairs over one period ``[0, N)``.
    misses:
        ``z_s``: phases of ``[0, N)`` at which sensor ``s`` is not in the set.
    """

    slots: tuple[tuple[int, int], ...]
    misses: tuple[int, ...]


@dataclass(frozen=True)
class BlockConstraints:
    """The half-spaces ``sum_s z_s(F) u_s > N log beta`` of one FMO block with ``|alpha| >= 1``.

    Attributes
    ----------
    eigenvalues:
        Exact texts of the block's eigenvalues.
    beta:
        ``|alpha|^2`` exactly, or ``None`` when only its float is known.
    beta_float:
        ``|alpha|^2`` as a float.
    period:
        ``N``.
    patterns:
        The binding patterns: componentwise-minimal ``z`` vectors only.
    certified:
        The block structure and every rank decision behind ``patterns`` were
        confirmed exactly (:attr:`kfio.sigma._sigma.SigmaResult.certified`).
    notes:
        Remarks carried over from the FMO and sigma steps.
    """

    eigenvalues: tuple[str, ...]
    beta: AlgebraicReal | None
    beta_float: float
    period: int
    patterns: tuple[BlindPattern, ...]
    certified: bool
    notes: tuple[str, ...] = ()
    beta_expr: Any = field(default=None, repr=False, compare=False)
    beta_mp: Any = field(default=None, repr=False, compare=False)  # beta at DIGITS digits (certified root)

    @property
    def beta_text(self) -> str:
        return self.beta.text() if self.beta is not None else repr(self.beta_float)

    def log_beta_power(self) -> mpmath.mpf:
        """``N log beta`` at :data:`DIGITS` digits."""
        with mpmath.workdps(DIGITS + 10):
            return self.period * mpmath.log(self._beta_mp())

    def _beta_mp(self) -> mpmath.mpf:
        if self.beta_mp is not None:
            return self.beta_mp
        return self.beta.approx(DIGITS) if self.beta is not None else mpmath.mpf(self.beta_float)


def _misses(slots: frozenset[tuple[int, int]], period: int, sensors: int) -> tuple[int, ...]:
    return tuple(period - sum(1 for n, g in slots if g == s) for s in range(sensors))


def minimal_patterns(patterns: Sequence[BlindPattern]) -> tuple[BlindPattern, ...]:
    """Keep one pattern per componentwise-minimal ``z`` vector (the others never bind).

    Examples
    --------
    >>> ps = [BlindPattern(((0, 0),), (0, 1)), BlindPattern(((0, 1),), (1, 0)), BlindPattern((), (1, 1))]
    >>> [p.misses for p in minimal_patterns(ps)]
    [(0, 1), (1, 0)]
    """
    unique: dict[tuple[int, ...], BlindPattern] = {}
    for p in sorted(patterns, key=lambda p: (p.misses, p.slots)):
        unique.setdefault(p.misses, p)
    zs = list(unique)
    keep = [z for z in zs if not any(w != z and all(a <= b for a, b in zip(w, z)) for w in zs)]
    return tuple(unique[z] for z in sorted(keep))


def _unstable_modulus(block: FmoBlock) -> bool:
    """``|alpha| >= 1``, exactly when ``beta`` is known (the same test as the verdict)."""
    if block.phase is None:
        return False
    if block.modulus_sq is not None:
        return block.modulus_sq.compare_power(1, Fraction(1)) >= 0
    return block.modulus_sq_float >= 1.0


def _certify_maximal(block: FmoBlock, patterns: Sequence[BlindPattern], budget: Budget | None) -> tuple[bool, str]:
    """Confirm in exact arithmetic that every binding pattern is blind and maximal.

    :func:`kfio.sigma._sigma.compute_sigma` confirms the rank drop of every
    maximal blind set and the maximality of the worst one; the region needs
    every binding pattern, so each one-slot extension of each is checked here
    (``rank = L`` exactly; rank is shift invariant, phases taken mod ``N0``).

    Raises
    ------
    NumericalFailure
        Exact arithmetic contradicts the numerical enumeration.
    """
    phase = block.phase
    assert phase is not None
    oracle = phase.exact_rank
    if oracle is None:
        return False, "binding patterns not confirmed exactly: no exact rank oracle for this block"
    L, N0, G = phase.n_columns, phase.base_period, len(phase.row_groups)
    checks = 0
    for p in patterns:
        base = {(n % N0, g) for n, g in p.slots}
        if len(base) == N0 * G:
            continue  # every slot: the block is unobservable, nothing to extend
        for slot in ((n, g) for n in range(N0) for g in range(G)):
            if slot in base:
                continue
            if budget is not None:
                budget.tick("regions: exact maximality checks")
            rank = oracle(sorted(base | {slot}))
            checks += 1
            if rank is None:
                return False, "binding patterns not confirmed exactly: the exact oracle gave no answer"
            if rank < L:
                raise NumericalFailure(
                    f"the blind set {sorted(base)} is not maximal in exact arithmetic (adding {slot} keeps rank {rank} < {L})"
                )
    return True, f"binding patterns confirmed maximal by {checks} exact ranks"


def block_constraints(
    system: System,
    budget: Budget | None = None,
    fmo: Sequence[FmoBlock] | None = None,
    sigma: Sequence[SigmaResult | None] | None = None,
) -> tuple[BlockConstraints, ...]:
    """The constraints of every FMO block with ``|alpha| >= 1`` (blocks inside the unit circle impose none).

    Parameters
    ----------
    system:
        The plant; ``system.sensors`` (or the single packet) define the row groups.
    budget:
        Work budget for the eigenstructure and the blind-set enumeration.
    fmo:
        The blocks of ``fmo_blocks(system)`` if the caller already has them.
    sigma:
        ``compute_sigma`` results aligned with ``fmo`` (``None`` entries are
        computed here) for Bernoulli channels: with several sensors the
        enumeration of maximal blind sets does not depend on the arrival
        probabilities, so ``analyze``'s results can be reused.

    Examples
    --------
    Liu and Goldsmith (2004), Section VI.B: ``A = diag(5/2, 3/2)``, one sensor per state.

    >>> from fractions import Fraction as F
    >>> from kfio.model import Sensor
    >>> s = System(A=((F(5, 2), F(0)), (F(0), F(3, 2))), C=((F(1), F(0)), (F(0), F(1))),
    ...            sensors=(Sensor("s1", (0,)), Sensor("s2", (1,))))
    >>> [(b.beta_text, [p.misses for p in b.patterns]) for b in block_constraints(s)]
    [('25/4', [(1, 0)]), ('9/4', [(0, 1)])]
    """
    blocks = fmo if fmo is not None else fmo_blocks(system, budget)
    if sigma is not None and len(sigma) != len(blocks):
        raise InvalidInput("/", "sigma results must be aligned with the FMO blocks (one per block, in order)")
    sensors = len(system.sensors) if system.sensors is not None else 1
    out = []
    for i, block in enumerate(blocks):
        if not _unstable_modulus(block):
            continue
        assert block.phase is not None
        given = sigma[i] if sigma is not None else None
        res = given if given is not None else compute_sigma(block.phase, [_PROBE] * sensors, budget)
        N = res.period
        sets = res.maximal_blind_sets or (res.worst_blind_set,)
        patterns = minimal_patterns([BlindPattern(tuple(sorted(F)), _misses(F, N, sensors)) for F in sets])
        maximal, note = _certify_maximal(block, patterns, budget) if res.certified else (False, "")
        out.append(
            BlockConstraints(
                eigenvalues=block.eigenvalue_texts,
                beta=block.modulus_sq,
                beta_float=block.modulus_sq_float,
                period=N,
                patterns=patterns,
                certified=res.certified and maximal and block.certified and block.modulus_sq is not None,
                notes=tuple(block.notes) + tuple(res.notes) + ((note,) if note else ()),
                beta_expr=block.modulus_sq.expr() if block.modulus_sq is not None else None,
                beta_mp=block.modulus_sq.approx(DIGITS) if block.modulus_sq is not None else None,
            )
        )
    return tuple(out)


def loss_product(misses: Sequence[int], lambdas: Sequence[Fraction], skip: int | None = None) -> Fraction:
    """``prod_{s != skip} (1 - lambda_s)^{z_s}`` exactly (``0^0 = 1``)."""
    c = Fraction(1)
    for s, (z, lam) in enumerate(zip(misses, lambdas)):
        if s != skip and z:
            c *= (1 - lam) ** z
    return c


def rate_sign(block: BlockConstraints, c: Fraction) -> tuple[int, bool]:
    """Sign of ``beta^N c - 1`` and whether it was decided exactly.

    A 30-digit evaluation settles clear cases; values within ``1e-20`` of 1
    go to :func:`kfio.sigma._decide.compare_rate_bernoulli` (exact whenever
    ``beta`` is known exactly).
    """
    if c == 0:
        return -1, True
    if block.beta is not None and block.beta.is_rational:
        assert block.beta.rational is not None
        v = block.beta.rational**block.period * c - 1
        return (v > 0) - (v < 0), True
    if block.beta is not None:
        with mpmath.workdps(40):
            v = block._beta_mp() ** block.period * (mpmath.mpf(c.numerator) / c.denominator) - 1
            if abs(v) > mpmath.mpf(10) ** -20:
                return (1 if v > 0 else -1), True
    return compare_rate_bernoulli(block.beta, block.beta_float, block.period, c)


def block_sign(block: BlockConstraints, lambdas: Sequence[Fraction]) -> tuple[int, bool]:
    """Sign of ``rate^N - 1`` for one block at ``lambdas``: ``1`` unstable, ``0`` boundary, ``-1`` stable."""
    worst, exact = -1, True
    for p in block.patterns:
        s, ex = rate_sign(block, loss_product(p.misses, lambdas))
        worst, exact = max(worst, s), exact and ex
    return worst, exact


def block_rate(block: BlockConstraints, lambdas: Sequence[float]) -> float:
    """``|alpha|^2 sigma = beta * max_F prod_s (1 - lambda_s)^{z_s / N}`` as a float."""
    best = max(
        (mpmath.fprod((1 - mpmath.mpf(lam)) ** z for z, lam in zip(p.misses, lambdas) if z) for p in block.patterns),
        default=mpmath.mpf(0),
    )
    return float(block.beta_float * best ** (mpmath.mpf(1) / block.period))


def power_expr(block: BlockConstraints) -> Any:
    """``beta^N`` as an exact SymPy expression (a float when ``beta`` is not exact)."""
    base = block.beta_expr if block.beta_expr is not None else sympy.Float(block.beta_float, 30)
    return base**block.period


def rational(x: Fraction) -> sympy.Rational:
    return sympy.Rational(x.numerator, x.denominator)


__all__ = [
    "BlindPattern",
    "BlockConstraints",
    "block_constraints",
    "block_rate",
    "block_sign",
    "loss_product",
    "minimal_patterns",
    "power_expr",
    "rate_sign",
]
