"""``sigma_k``: the decay rate of the probability of staying blind (Rohr, Marelli and Fu (2014), Lemma 3).

For one reduced FMO block in phase form (:class:`~kfio.structure._phases.PhaseBlock`)
and one channel per row group,

.. math::

    \\sigma = \\limsup_{t\\to\\infty} P(\\text{blind after } t \\text{ steps})^{1/t}
           = \\max_{F \\text{ maximal blind}} \\rho(M_F),

Rohr, Marelli and Fu (2014), eq. (33), in the per-step form of docs/theory.md: ``M_F`` acts
on states (phase ``n`` in ``[0, N)``, joint history ``h``); from ``(n, h)``
each group ``g`` emits ``g_t`` with probability ``P(g_t | h_g)``, emitting 1 at
slot ``(n, g)`` only if ``(n, g)`` is in ``F``.  Its ``N``-step product is the
one-period matrix ``P_F`` of :func:`period_transfer_matrix` and
``rho(P_F) = rho(M_F)^N = sigma_F^N`` (the ``p_i`` of Rohr, Marelli and Fu (2014), eq. (31)).

Groups are independent, so ``P_F`` is the Kronecker product of one matrix per
group (mixed-product property) and ``rho(P_F) = prod_g rho(P_{F,g})``.  For a
Bernoulli group ``rho(P_{F,g}) = (1 - lambda_g)^{z_g}`` with ``z_g`` the phases
where ``g`` is not in ``F`` (Rohr, Marelli and Fu (2014), Corollary 2); for a Gilbert-Elliott
group it is a product over the missed phases (:class:`_RenewalScore`).  Blind
sets themselves come from :mod:`kfio.search._blind`; with one Markov packet
:class:`_WindowBound` sharpens its window bound.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from fractions import Fraction
from typing import TYPE_CHECKING, Sequence

import numpy as np

from .._budget import Budget
from ..errors import AssumptionViolation, BudgetExceeded, InvalidInput, NumericalFailure
from ..model import MarkovChannel
from ..search import (
    FrontBudgetExceeded,
    Margins,
    Objective,
    PartialFront,
    SlotSpace,
    enumerate_orbits,
    largest_blind_bound,
    pareto_search,
    search,
)
from ..structure import PhaseBlock, Slot

if TYPE_CHECKING:  # annotations only: sigma's layer does not import kfio._reuse at run time
    from .._reuse import Memo


#: Closure-search steps allowed when the caller passes no budget.
DEFAULT_MAX_STEPS = 200_000

#: Most float entries a batch of transfer products may hold at once.
_BATCH_ENTRIES = 1 << 21


@dataclass(frozen=True)
class SigmaResult:
    """``sigma_k`` of one FMO block and the blind set that attains it.

    Attributes
    ----------
    period:
        ``N``: the smallest multiple of ``block.base_period`` that is
        ``>= max(nu, 1)``, ``nu`` the largest channel order.
    sigma:
        ``limsup_t P(blind after t steps)^(1/t)`` (Rohr, Marelli and Fu (2014), eq. (33)).
    rho_period:
        ``sigma ** N``: spectral radius of the one-period transfer matrix of
        :attr:`worst_blind_set`.
    degenerate:
        The phase-0 rows of all groups stacked lack full column rank ``L``
        (Rohr, Marelli and Fu (2014), Definition 5).
    fully_blind:
        All slots together are rank-deficient (an unobservable mode); then
        ``sigma = 1``.
    worst_blind_set:
        A maximal blind set of slots ``(n, g)``, ``n`` in ``[0, N)``,
        attaining ``sigma``.
    maximal_blind_sets:
        Several packets: with a Markov channel among them, one representative
        per shift orbit of every maximal blind set; with Bernoulli channels
        only, one maximal blind set per undominated miss vector ``z`` (the
        only ones that can attain ``sigma`` or bind a region, whatever the
        arrival probabilities: Rohr, Marelli and Fu (2014), Corollary 2).
        One packet: ``()`` if only the worst one was searched.
    bernoulli_exponents:
        Only if every channel is Bernoulli: ``z_g / N`` per group for the
        worst set, ``z_g`` the phases ``n`` with ``(n, g)`` not in it; then
        ``sigma = prod_g (1 - lambda_g)^(z_g / N)``.
    certified:
        Every rank decision that matters (rank drop of each reported maximal
        blind set, full rank of each one-slot extension of the worst set, the
        degeneracy test) was confirmed by ``block.exact_rank``.
    notes:
        Method and certification remarks.
    """

    period: int
    sigma: float
    rho_period: float
    degenerate: bool
    fully_blind: bool
    worst_blind_set: frozenset[tuple[int, int]]
    maximal_blind_sets: tuple[frozenset[tuple[int, int]], ...]
    bernoulli_exponents: tuple[Fraction, ...] | None
    certified: bool
    notes: tuple[str, ...]


def sigma_period(base_period: int, channels: Sequence[MarkovChannel]) -> int:
    """``N``: the smallest multiple of ``base_period`` that is ``>= max(nu, 1)``.

    Examples
    --------
    >>> from fractions import Fraction as F
    >>> ch = MarkovChannel("markov", 3, tuple(F(1, 2) for _ in range(8)))
    >>> sigma_period(2, [ch])
    4
    """
    nu = max([1] + [ch.order for ch in channels])
    return base_period * -(-nu // base_period)


def _check_inputs(block: PhaseBlock, channels: Sequence[MarkovChannel], memo: Memo | None = None) -> None:
    if memo is None or "block checked" not in memo:  # the block alone: once per memo
        if block.n_columns == 0:
            raise InvalidInput("/system", "a phase block needs at least one column")
        if not np.isfinite(block.c_hat).all():
            raise InvalidInput("/system", "the reduced observation matrix C_hat has entries that are not finite")
        if memo is not None:
            memo["block checked"] = True
    if len(channels) != len(block.row_groups):
        raise InvalidInput(
            "/channel", f"expected one channel per packet ({len(block.row_groups)}), got {len(channels)}"
        )
    for ch in channels:
        if any(not 0 < p < 1 for p in ch.table):
            raise AssumptionViolation(
                "/channel",
                "every arrival probability must lie strictly between 0 and 1 (Rohr, Marelli and Fu 2014, Assumption 1)",
            )


def _step_matrices(channel: MarkovChannel) -> tuple[np.ndarray, np.ndarray]:
    """Float one-step matrices ``(T_all, T_loss)`` on histories: every emission, and loss only."""
    k = channel.n_histories
    full, loss = np.zeros((k, k)), np.zeros((k, k))
    for h in range(k):
        p1 = float(channel.table[h])
        full[h, channel.next_history(h, 1)] += p1
        full[h, channel.next_history(h, 0)] += 1.0 - p1
        loss[h, channel.next_history(h, 0)] += 1.0 - p1
    return full, loss


def _pattern_products(full: np.ndarray, loss: np.ndarray, m: int) -> np.ndarray:
    """Products over ``m`` phases for every pattern; bit ``i`` set: arrivals allowed at phase ``i``."""
    table = np.stack([loss, full])
    for _ in range(1, m):
        table = np.concatenate([table @ loss, table @ full])
    return table


class _GroupRho:
    """``log rho`` of one group's product of step matrices over ``N0`` phases, for many sets at once.

    The chain is time-homogeneous, so the product over ``b`` consecutive
    phases depends only on which of them allow arrivals: the ``2^b``
    products are tabulated once and a period costs ``ceil(N0 / b)`` batched
    products.  Bernoulli groups use the closed form ``(1 - lambda)^z``.
    """

    def __init__(self, channel: MarkovChannel, n_phases: int) -> None:
        self.n_phases = n_phases
        self.k = channel.n_histories
        self.log_loss = math.log(1.0 - float(channel.table[0]))
        full, loss = _step_matrices(channel)
        self.chunk = max(1, min(8, n_phases, int(math.log2(max(2, _BATCH_ENTRIES // self.k**2)))))
        lengths = {self.chunk, n_phases % self.chunk} - {0}
        self.tables = {m: _pattern_products(full, loss, m) for m in lengths} if channel.order else {}

    def __call__(self, allowed: np.ndarray) -> np.ndarray:
        """``log rho`` per row of ``allowed`` (``(C, N0)``: phases where arrivals are allowed)."""
        if not self.tables:
            log_rho: np.ndarray = (~allowed).sum(axis=1) * self.log_loss
            return log_rho
        batch = max(1, _BATCH_ENTRIES // self.k**2)
        return np.concatenate([self._log_rho(allowed[i : i + batch]) for i in range(0, allowed.shape[0], batch)])

    def _log_rho(self, allowed: np.ndarray) -> np.ndarray:
        C = allowed.shape[0]
        prod = np.broadcast_to(np.eye(self.k), (C, self.k, self.k)).copy()
        log_scale = np.zeros(C)
        for start in range(0, self.n_phases, self.chunk):
            m = min(self.chunk, self.n_phases - start)
            code = allowed[:, start : start + m].astype(np.int64) @ (1 << np.arange(m))
            prod = prod @ self.tables[m][code]
            # The product decays like (1 - q)^n: rescale and carry the scale.
            top = prod.max(axis=(1, 2))
            prod /= top[:, None, None]
            log_scale += np.log(top)
        log_rho: np.ndarray = np.log(np.abs(np.linalg.eigvals(prod)).max(axis=1)) + log_scale
        return log_rho


class _LogRho:
    """``log rho(P_F)`` for base-slot masks ``(C, N0 G)`` (index ``n G + g``).

    ``rho(P_F) = prod_g rho(P_{F,g})`` (Kronecker structure), and a blind set
    lifted from ``[0, N0)`` is ``N0``-periodic, so ``P_F = (P_F^{(N0)})^(N / N0)``:
    only ``N0`` steps are multiplied.
    """

    def __init__(self, channels: Sequence[MarkovChannel], base_period: int, period: int) -> None:
        self.groups = [_GroupRho(ch, base_period) for ch in channels]
        self.base_period = base_period
        self.repeats = period // base_period

    def __call__(self, masks: np.ndarray) -> np.ndarray:
        per_group = masks.reshape(masks.shape[0], self.base_period, len(self.groups))
        total = sum(rho(per_group[:, :, g]) for g, rho in enumerate(self.groups))
        return np.asarray(total, dtype=float) * self.repeats


class _RenewalScore:
    """Exact ``log rho(P_F)`` of one order-1 group (Gilbert-Elliott), from the gaps between misses.

    A loss step sends every history to ``h = 0``: ``T_loss = c e_0^T`` with
    ``c_h = P(g = 0 | h)``.  A period with at least one missed phase is
    therefore a product of rank-one blocks, one per missed phase ``m``: the
    block from ``m`` to the next missed phase ``m'`` is ``T_all^a T_loss``,
    ``a = m' - m - 1`` allowed phases in between, and cyclically

    .. math::

        \\rho(P_F) = \\operatorname{tr} P_F = \\prod_{\\text{missed } m} f(a_m),
        \\qquad f(a) = e_0^T T_{all}^a c,

    the probability of a loss ``a + 1`` steps after a loss with no constraint
    in between (a renewal argument: after a loss the history is known).  A
    set that misses nothing has ``rho = 1``.  One score is a few array
    operations per batch: no matrix products, no eigenvalues.
    """

    def __init__(self, channel: MarkovChannel, n_phases: int, repeats: int) -> None:
        full, loss = _step_matrices(channel)
        column, f = loss[:, 0].copy(), np.empty(n_phases)
        for a in range(n_phases):
            f[a] = column[0]
            column = full @ column
        self.log_f = np.log(f) * repeats
        self.n_phases = n_phases

    def __call__(self, masks: np.ndarray) -> np.ndarray:
        """``log rho(P_F)`` per row of ``masks`` (``(C, N0)``: phases where arrivals are allowed)."""
        N = self.n_phases
        missed = ~masks.astype(bool)
        twice = np.concatenate([missed, missed], axis=1)
        # First missed phase at or after each index of the doubled cycle.
        first = np.minimum.accumulate(np.where(twice, np.arange(2 * N), 2 * N)[:, ::-1], axis=1)[:, ::-1]
        gaps = np.clip(first[:, 1 : N + 1] - np.arange(1, N + 1), 0, N - 1)
        values_out: np.ndarray = np.where(missed, self.log_f[gaps], 0.0).sum(axis=1)
        return values_out


class _WindowBound:
    """``M(c)``: an upper bound on ``log rho(P_F)`` over every phase pattern whose windows all miss ``>= c`` phases.

    A window is ``W`` consecutive phases (cyclically).  Canonical rotation
    (:mod:`kfio.search._blind`) puts the fewest misses of a set in window 0, so a
    set whose window 0 misses ``c`` phases has every window missing at least
    ``c``, and it cannot beat an incumbent scoring more than ``M(c)``.

    ``M(c)`` comes from a dynamic program over the ``N0`` phases of one
    period, rotated to end with a missed phase.  The state after a phase is
    the set of offsets (``0 .. W - 1`` phases back) of the ``c`` most recent
    missed phases: every window has ``c`` misses iff they always fit in
    ``W`` phases, and a period is a closed walk from the state at its last
    phase back to it.  The value of a state is a row vector, the entrywise
    maximum of ``x0 T_1 ... T_t`` over the patterns that reach it.  All
    matrices are non-negative, so every pattern's product satisfies ``x0 P
    <= X`` entrywise, ``X`` the final value of its start state, and
    Collatz-Wielandt gives ``rho(P) <= max_i X_i / x0_i`` for any ``x0 > 0``.
    ``x0`` starts on the histories that follow a loss (the last phase was
    missed) and is refined by power iteration (the final vector of each
    start state becomes its next ``x0``); every round gives a valid bound and
    the smallest is kept.  For Gilbert-Elliott a loss resets the history, so
    patterns merged in a state share their direction and the first round
    loses only the choice among them.
    """

    #: Most float entries (start states x predecessor slots x histories x phases) one round may touch
    #: (about 0.4 s); a larger round is not run.
    MAX_WORK = 1 << 27

    #: Rounds of ``x0`` at most (the second one has settled every case measured).
    ROUNDS = 2

    #: Smallest value kept, relative to the largest of each start state after every phase.
    FLOOR = 1e-250

    #: A second round is tried only if the first is within this fraction of the target (it moved
    #: order-2 and order-3 bounds by 3-15 % where measured).
    REFINE_MARGIN = 0.2

    def __init__(self, full: np.ndarray, loss: np.ndarray, n_phases: int, repeats: int) -> None:
        self.full, self.loss = full, loss
        self.n_phases, self.repeats = n_phases, repeats
        # A loss resets an order-1 history: its first round is as good as any.
        self.refine = full.shape[0] > 2
        self._state: dict[tuple[int, int], tuple[float, int, np.ndarray | None]] = {}

    def max_log_rho(self, W: int, c: int, rounds: int = ROUNDS) -> float | None:
        """``M(c)`` for windows of ``W`` phases after ``rounds`` of ``x0``, or ``None`` if too large to run."""
        if not 1 <= c <= W <= self.n_phases:
            return None
        key = (W, c)
        bound, done, x0 = self._state.get(key, (np.inf, 0, None))
        while done < rounds:
            if done and x0 is None:
                break  # nothing left to refine (no start state, or a round changed nothing)
            step = self._round(W, c, x0)
            if step is None:
                return None
            value, x0 = step
            x0 = None if value >= bound * (1 - 1e-12) else x0
            bound, done = min(bound, value), done + 1
        self._state[key] = (bound, done, x0)
        return bound * self.repeats

    @staticmethod
    @functools.lru_cache(maxsize=64)
    def _graph(W: int, c: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """States, ordered: the ``A`` after an allowed phase, then the ones after a missed phase.

        A state is a ``W``-bit mask with ``c`` bits (bit ``o``: a miss ``o``
        phases back).  Returns the masks, the one predecessor of each state
        after an allowed phase, and the predecessors of each state after a
        missed phase (padded with the index ``S``, a state that stays empty).
        """
        masks = sorted((m for m in range(1 << W) if bin(m).count("1") == c), key=lambda m: m & 1)
        index = {m: i for i, m in enumerate(masks)}
        allowed = [index[m >> 1] for m in masks if not m & 1]  # shifting drops nothing: one predecessor
        missed: list[list[int]] = [[] for m in masks if m & 1]
        first = len(allowed)
        for i, m in enumerate(masks):
            hit = (m << 1) | 1  # a missed phase joins, the oldest of the c drops out
            missed[index[hit ^ (1 << (hit.bit_length() - 1))] - first].append(i)
        table = np.full((len(missed), max(map(len, missed))), len(masks))
        for i, p in enumerate(missed):
            table[i, : len(p)] = p
        return np.array(masks), np.array(allowed, dtype=int), table

    def _round(self, W: int, c: int, x0: np.ndarray | None) -> tuple[float, np.ndarray | None] | None:
        """One pass of the program: ``(bound on log rho over one base period, next x0)``."""
        k = self.full.shape[0]
        masks, after_allowed, after_missed = self._graph(W, c)
        S, A = masks.size, after_allowed.size
        starts = np.flatnonzero(masks & 1)  # the last phase of the period is missed
        if starts.size * (A + after_missed.size) * k * self.n_phases > self.MAX_WORK:
            return None
        if x0 is None:
            x0 = np.tile(np.where(np.arange(k) & 1 == 0, 1.0, 1e-12), (starts.size, 1))
        B = np.arange(starts.size)
        X = np.zeros((starts.size, S + 1, k))  # the last state stays empty (padding of the predecessors)
        X[B, starts] = x0
        log_scale = np.zeros(starts.size)
        for _ in range(self.n_phases):
            Y = np.zeros_like(X)
            Y[:, :A] = X[:, after_allowed] @ self.full
            Y[:, A:S] = X[:, after_missed].max(axis=2) @ self.loss
            top = Y.max(axis=(1, 2))
            live = top > 0
            Y[live] /= top[live, None, None]
            log_scale[live] += np.log(top[live])
            log_scale[~live] = -np.inf
            # Raising a value only loosens the bound; this keeps a product that is tiny next to the
            # largest one from underflowing to zero (which would tighten it wrongly).
            np.maximum(Y[:, :S], self.FLOOR, out=Y[:, :S])
            X = Y
        final = X[B, starts]
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(final > 0, final / x0, 0.0).max(axis=1)
            value = float((np.log(ratio) + log_scale).max())
        top = final.max(axis=1, keepdims=True)
        return value, np.where(top > 0, final / np.where(top > 0, top, 1.0), x0) + 1e-12

    def window_misses(self, threshold: float, W: int, start: int, known: int) -> int:
        """Largest ``c`` in ``(known, start]`` the program cannot exclude (``M(c) >= threshold``), else ``known``.

        ``known`` is a ``c`` some real pattern scoring ``>= threshold`` attains
        (the incumbent's fewest window misses), so nothing at or below it
        needs the program.  One round of ``x0`` settles most ``c``; the
        refined bound is computed only for a ``c`` that one round cannot
        exclude.
        """
        for c in range(min(start, W), known, -1):
            rough = self.max_log_rho(W, c, rounds=1)
            if rough is None:
                return c  # too large to run: c stays possible
            if rough < threshold:
                continue
            if not self.refine or rough - threshold > self.REFINE_MARGIN * abs(threshold):
                return c
            refined = self.max_log_rho(W, c)
            if refined is None or refined >= threshold:
                return c
        return max(known, 0)


def _objective(channels: Sequence[MarkovChannel], base_period: int, period: int, reference: bool = False) -> Objective:
    """Branch-and-bound score and its bounds.

    One Bernoulli packet: the score is ``|F|`` (Corollary 2), and beating the
    incumbent means missing at most ``S - |F_best| - 1`` slots.  Otherwise
    the score is ``log rho(P_F)`` (for one Gilbert-Elliott packet in the
    closed form of :class:`_RenewalScore`); since ``rho <= ||P_F||_inf`` and
    each loss-only step has row sums at most ``m0 = max_h P(g = 0 | h)``, a
    set missing ``w`` base slots has ``log rho(P_F) <= (N / N0) w max_g log m0_g``.

    One Markov packet (order >= 1): :class:`_WindowBound` sharpens the window
    bound of the search.  For Bernoulli it could not: a cyclic pattern all
    of whose windows miss ``>= c`` phases misses at least ``ceil(c N0 / W)``
    and evenly spread misses attain that, which is the averaging bound.
    ``reference=True`` leaves out the renewal score and the window bound
    (the slower route of the tests).
    """
    size = base_period * len(channels)
    repeats = period // base_period
    if len(channels) == 1 and channels[0].order == 0:
        return Objective(score=_count, max_weight=lambda best: size - int(best) - 1)
    per_miss = repeats * max(math.log(float(max(1 - p for p in ch.table))) for ch in channels)

    def max_weight(best: float) -> int:
        # Slack so that round-off in ``best`` never excludes a set that ties.
        return min(size, math.ceil(best / per_miss * (1 + 1e-9) + 1e-9) - 1)

    if len(channels) > 1 or reference:
        return Objective(score=_LogRho(channels, base_period, period), max_weight=max_weight)
    channel = channels[0]
    score = (
        _RenewalScore(channel, base_period, repeats) if channel.order == 1 else _LogRho(channels, base_period, period)
    )
    windows = _WindowBound(*_step_matrices(channel), base_period, repeats)

    def window_misses(best: float, W: int, known: int) -> int | None:
        target = best - 1e-9 * max(1.0, abs(best))  # slack as above: a set that ties is never excluded
        return windows.window_misses(target, W, W * max_weight(best) // base_period, known)

    return Objective(score=score, max_weight=max_weight, window_misses=window_misses)


def _count(masks: np.ndarray) -> np.ndarray:
    arr: np.ndarray = masks.sum(axis=1).astype(float)
    return arr


def period_transfer_matrix(
    period: int, blind_set: frozenset[tuple[int, int]], channels: Sequence[MarkovChannel], budget: Budget | None = None
) -> list[list[Fraction]]:
    """Exact one-period transfer matrix ``P_F`` over the joint channel history.

    ``[P_F]_{h, h'}`` is the probability that, starting at phase 0 with joint
    history ``h``, the next ``period`` steps emit arrivals only at slots of
    ``blind_set`` and end in joint history ``h'``.  The joint history is
    ``h = (h_0, ..., h_{G-1})`` with group 0 most significant (Kronecker
    order), each ``h_g`` in the bit convention of :class:`MarkovChannel`.
    ``rho(P_F) = sigma_F^N`` (Rohr, Marelli and Fu (2014), eqs. (30)-(31) in per-step form).

    Parameters
    ----------
    period:
        ``N``.
    blind_set:
        Slots ``(n, g)``; phases are taken modulo ``period``.
    channels:
        One channel per row group.
    budget:
        Checked once per history and step (a Markov channel of order 10 has
        1,024 histories: each step then costs about a million exact products).

    Examples
    --------
    Gilbert-Elliott (``q = 1/4``, ``p = 1/2``) on Rohr, Marelli and Fu (2014)'s Example 1 with
    the blind set ``{phase 0}``: ``rho = (1 - q)^2 + p q``.

    >>> ch = MarkovChannel("gilbert_elliott", 1, (Fraction(1, 4), Fraction(1, 2)))
    >>> period_transfer_matrix(2, frozenset({(0, 0)}), [ch])
    [[Fraction(11, 16), Fraction(0, 1)], [Fraction(5, 8), Fraction(0, 1)]]
    """
    result = [[Fraction(1)]]
    for g, ch in enumerate(channels):
        phases = {n % period for n, grp in blind_set if grp == g}
        result = _kron(result, _group_period_matrix(ch, period, phases, budget))
    return result


def _group_period_matrix(
    channel: MarkovChannel, period: int, phases: set[int], budget: Budget | None = None
) -> list[list[Fraction]]:
    """Exact product over ``period`` steps; each step has two non-zeros per row, so it costs ``O(k^2)``."""
    k = channel.n_histories
    zero, one = Fraction(0), Fraction(1)  # shared (immutable): k^2 entries are not k^2 constructions
    prod = [[one if r == c else zero for c in range(k)] for r in range(k)]
    for n in range(period):
        emissions = (0, 1) if n in phases else (0,)
        nxt = [[zero] * k for _ in range(k)]
        for h in range(k):
            if budget is not None:
                budget.tick("exact transfer matrices", k)
            p1 = channel.arrival(h)
            for g in emissions:
                w, h2 = (p1 if g else 1 - p1), channel.next_history(h, g)
                for r in range(k):
                    if prod[r][h]:
                        nxt[r][h2] += prod[r][h] * w
        prod = nxt
    return prod


def _kron(a: list[list[Fraction]], b: list[list[Fraction]]) -> list[list[Fraction]]:
    return [[x * y for x in ra for y in rb] for ra in a for rb in b]


@dataclass(frozen=True)
class _Found:
    """Maximal blind sets on base slots, the worst one, and how they were found."""

    worst: np.ndarray
    maximal: tuple[np.ndarray, ...]
    enumerated: bool
    method: str


def _find_worst(
    space: SlotSpace,
    block_exponents: Sequence[int],
    channels: Sequence[MarkovChannel],
    period: int,
    degenerate: bool,
    fully_blind: bool,
    budget: Budget,
    margins: Margins,
) -> _Found:
    """Pick the route: special cases, branch and bound (one group), or enumeration."""
    if fully_blind:
        everything = np.ones(space.size, dtype=bool)
        return _Found(everything, (everything,), True, "every slot together is rank-deficient: sigma = 1")
    if space.n_groups == 1 and not degenerate:
        empty = np.zeros(space.size, dtype=bool)
        return _Found(
            empty,
            (empty,),
            True,
            "non-degenerate block: only the empty set is blind (Rohr, Marelli and Fu 2014, Lemma 2)",
        )
    objective = _objective(channels, space.n_phases, period)
    if space.n_groups == 1:
        bound = None
        if channels[0].order == 0 and space.rows.shape[1] == 1:
            bound = largest_blind_bound(space.n_phases, block_exponents, budget)
            if bound is not None:
                objective = dataclasses.replace(objective, enough=float(bound))
        res = search(space, budget, margins, objective)
        what = "largest blind set (Corollary 2)" if channels[0].order == 0 else "blind set of largest rho(M_F)"
        method = (
            f"branch and bound for the {what}: {res.nodes} flats expanded, {res.planes} resolved in batch, "
            f"window {res.window}"
        )
        if res.stopped:
            method += f", stopped at the cyclic-code bound (no blind set holds more than {int(bound or 0)} phases)"
        return _Found(res.maximal[0], (), False, method)
    if all(ch.order == 0 for ch in channels):
        res = pareto_search(space, budget, margins, block_exponents)
        vectors = f"{len(res.maximal)} undominated vector{'' if len(res.maximal) == 1 else 's'}"
        proof = f"proved from the big flats of one sensor at a time ({res.checked} checked)"
        if res.checked is None:
            method = f"Pareto branch and bound over per-sensor miss counts: {vectors} over {res.nodes} flats"
        elif res.nodes == 0:
            method = f"Pareto front of per-sensor miss counts: {vectors}, {proof}"
        else:
            method = f"Pareto branch and bound over per-sensor miss counts: {vectors} over {res.nodes} flats, completed and {proof}"
    else:
        res = enumerate_orbits(space, budget, margins)
        method = f"enumerated {len(res.maximal)} shift orbits of maximal blind sets over {res.nodes} flats"
    return _Found(_pick_worst(res.maximal, channels, space.n_phases, period), res.maximal, True, method)


def _pick_worst(
    maximal: Sequence[np.ndarray], channels: Sequence[MarkovChannel], base_period: int, period: int
) -> np.ndarray:
    """The set of ``maximal`` with the largest ``rho(P_F)`` under ``channels`` (the first of ties)."""
    objective = _objective(channels, base_period, period)
    return maximal[int(np.argmax(objective.score(np.array(maximal))))]


def _route(space: SlotSpace, channels: Sequence[MarkovChannel], degenerate: bool, fully_blind: bool) -> str | None:
    """The route of :func:`_find_worst` when the sets it searches do not depend on the probabilities, else ``None``.

    Channel-independence, route by route (what a per-plant memo may keep):

    * ``fully-blind`` and ``empty`` (one group, non-degenerate): the set is
      fixed by the ranks of the block's rows alone;
    * ``bernoulli`` (one Bernoulli group): the score is ``|F|`` and the bound
      is :func:`largest_blind_bound` of the block's exponents, so the search
      visits the same flats for every ``lambda`` (Corollary 2: the largest
      blind set is the worst whatever ``lambda``);
    * ``pareto`` (several groups, all Bernoulli): :func:`pareto_search` takes
      no channel; its front of undominated miss vectors is the same for every
      ``lambda_g`` (``rho(P_F) = prod_g (1 - lambda_g)^{z_g}`` is decreasing
      in each ``z_g``); only the argmax over the front depends on them;
    * ``orbits`` (several groups, a Markov one among them): every shift orbit
      is enumerated, with no channel; again only the argmax depends on them.

    One group with a Markov channel (order >= 1) searches with a score and a
    window bound built from its probabilities: ``None``, never kept.
    """
    if fully_blind:
        return "fully-blind"
    if space.n_groups == 1:
        if not degenerate:
            return "empty"
        return "bernoulli" if channels[0].order == 0 else None
    return "pareto" if all(ch.order == 0 for ch in channels) else "orbits"


def _lift(space: SlotSpace, mask: np.ndarray, period: int) -> frozenset[tuple[int, int]]:
    """Slots over ``[0, N)`` of a base mask (blindness depends on ``n mod N0`` only)."""
    return frozenset((n + k * space.n_phases, g) for n, g in space.slots(mask) for k in range(period // space.n_phases))


def undominated(space: SlotSpace, masks: Sequence[np.ndarray]) -> list[np.ndarray]:
    """The masks whose per-group miss counts ``z`` are componentwise minimal (ties all kept).

    With Bernoulli channels ``rho(P_F) = prod_g (1 - lambda_g)^{z_g}``
    (Rohr, Marelli and Fu 2014, Corollary 2) is strictly decreasing in every
    ``z_g``, so a set whose ``z`` is dominated never attains ``sigma`` and
    never binds a stability region, whatever the arrival probabilities.
    """
    if not masks:
        return []
    z = np.array([space.n_phases - m.reshape(space.n_phases, space.n_groups).sum(axis=0) for m in masks])
    u, which = np.unique(z, axis=0, return_inverse=True)  # at most (N0 + 1)^G distinct vectors
    below = (u[None, :, :] <= u[:, None, :]).all(axis=2) & (u[None, :, :] != u[:, None, :]).any(axis=2)
    dominated = below.any(axis=1)[which.reshape(-1)]
    return [m for m, d in zip(masks, dominated) if not d]


def _exact_checks(
    space: SlotSpace,
    found: _Found,
    margins: Margins,
    phase0: np.ndarray,
    degenerate: bool,
    bernoulli: bool = False,
) -> list[tuple[list[Slot], bool, str]]:
    """``(slots, expect_blind, what)`` for every rank decision that matters.

    A rank drop must be confirmed on the whole set; full rank may be
    confirmed on a subset (rank is monotone), so each extension of the worst
    set is checked with a spanning subset of it plus the new slot.  Slot
    ranks are shift invariant, so the extensions of the empty set need only
    phase 0.  With Bernoulli channels only the sets of :func:`undominated`
    miss counts can matter, so only their rank drops are confirmed.
    """
    checks = [(space.slots(phase0), degenerate, "phase-0 rows (degeneracy)")]
    sets = list(found.maximal or (found.worst,))
    if bernoulli:
        sets = undominated(space, sets)
    checks += [(space.slots(m), True, "maximal blind set") for m in sets]
    basis = space.spanning_subset(found.worst, margins)
    outside = ~found.worst if found.worst.any() else phase0
    for i in np.flatnonzero(outside):
        checks.append((space.slots(basis) + [divmod(int(i), space.n_groups)], False, "extension of the worst set"))
    return checks


def _certify(block: PhaseBlock, checks: list[tuple[list[Slot], bool, str]], budget: Budget) -> tuple[bool, str]:
    """Confirm ``checks`` with ``block.exact_rank``.

    Raises
    ------
    NumericalFailure
        When exact arithmetic contradicts a numerical rank decision.
    """
    oracle = block.exact_rank
    if oracle is None:
        return False, "ranks are numerical (SVD): no exact rank oracle for this block"
    L = block.n_columns
    for slots, expect_blind, what in checks:
        budget.tick("sigma: exact rank checks")
        rank = oracle(slots)
        if rank is None:
            return False, f"ranks are numerical (SVD): the exact oracle gave no answer for a {what}"
        if (rank < L) != expect_blind:
            raise NumericalFailure(f"exact rank {rank} of a {what} contradicts the numerical rank decision")
    return True, f"certified: {len(checks)} rank decisions confirmed in exact arithmetic"


def _unblind_shares(
    space: SlotSpace, mask: np.ndarray, channels: Sequence[MarkovChannel]
) -> tuple[Fraction, ...] | None:
    """``z_g / N = (phases of [0, N0) where g is not in F) / N0`` if all channels are Bernoulli."""
    if any(ch.order != 0 for ch in channels):
        return None
    per_group = mask.reshape(space.n_phases, space.n_groups)
    return tuple(Fraction(int((~per_group[:, g]).sum()), space.n_phases) for g in range(space.n_groups))


def _sigma_values(
    space: SlotSpace,
    found: _Found,
    channels: Sequence[MarkovChannel],
    period: int,
    exponents: tuple[Fraction, ...] | None,
) -> tuple[float, float]:
    """``(sigma, rho_period)``, in closed form where Rohr, Marelli and Fu (2014) gives one (Lemma 2, Corollary 2)."""
    if found.worst.all():
        return 1.0, 1.0
    if exponents is not None:
        sigma = math.prod(float(1 - ch.table[0]) ** float(z) for ch, z in zip(channels, exponents))
        return sigma, sigma**period
    if not found.worst.any():
        sigma = math.prod(float(ch.loss_after_losses) for ch in channels)
        return sigma, sigma**period
    log_rho = float(_LogRho(channels, space.n_phases, period)(found.worst[None, :])[0])
    return math.exp(log_rho / period), math.exp(log_rho)


@dataclass(frozen=True)
class SigmaBracket:
    """A certified bracket on ``sigma_k`` of independent Bernoulli sensors, from a search cut short.

    With Bernoulli channels ``rho(P_F) = prod_g (1 - lambda_g)^{z_g}`` over the
    ``N0`` base phases (Rohr, Marelli and Fu (2014), Corollary 2), so
    ``sigma^N0`` lies in ``[lower, upper]``:

    * ``lower`` is attained by a blind set (its rank drop is confirmed in exact
      arithmetic when ``lower_exact``; the empty set, always blind, when the
      search found nothing better): ``sigma >= lower^(1/N0)``;
    * every blind set misses at least ``upper_misses[g]`` phases of sensor
      ``g`` (each sensor alone: a subset of a blind set is blind), so
      ``sigma <= upper^(1/N0)`` with ``upper = prod_g (1 - lambda_g)^{upper_misses[g]}``
      (``1`` when those one-sensor searches did not finish).

    Attributes
    ----------
    phases:
        ``N0``, the base period of the block.
    lower, upper:
        ``sigma^N0`` bounds, exact rationals.
    lower_set:
        Slots ``(n, g)`` of the blind set attaining ``lower``.
    lower_misses, upper_misses:
        Per sensor, the phases missed by ``lower_set``, and the proved least
        misses (``None``: not proved).
    lower_exact:
        Whether ``lower_set``'s rank drop was confirmed in exact arithmetic.
    found:
        Miss vectors of every blind set the search had kept.
    """

    phases: int
    lower: Fraction
    upper: Fraction
    lower_set: tuple[tuple[int, int], ...]
    lower_misses: tuple[int, ...]
    upper_misses: tuple[int, ...] | None
    lower_exact: bool
    found: tuple[tuple[int, ...], ...]


class SigmaBudgetExceeded(BudgetExceeded):
    """:class:`~kfio.errors.BudgetExceeded` of :func:`compute_sigma` with the bracket proved so far."""

    def __init__(self, message: str, bracket: SigmaBracket) -> None:
        super().__init__(message)
        self.bracket = bracket


def sigma_bracket(
    block: PhaseBlock, space: SlotSpace, channels: Sequence[MarkovChannel], found: PartialFront
) -> SigmaBracket:
    """The bracket of :class:`SigmaBracket` from what a cut-short Pareto search found.

    Candidates for the lower end are the sets found and the empty set (blind
    whenever the block has a column); the best one whose rank drop the exact
    oracle confirms is taken (numerically decided sets count only when there
    is no oracle, and ``lower_exact`` then says so).  No budget is charged:
    one exact rank per candidate at most.
    """
    loss = [1 - ch.table[0] for ch in channels]
    N0, G = space.n_phases, space.n_groups

    def misses(mask: np.ndarray) -> tuple[int, ...]:
        return tuple(int(z) for z in N0 - mask.reshape(N0, G).sum(axis=0))

    def value(z: Sequence[int]) -> Fraction:
        return math.prod((q**k for q, k in zip(loss, z)), start=Fraction(1))

    empty = np.zeros(space.size, dtype=bool)
    candidates = sorted(list(found.masks) + [empty], key=lambda m: value(misses(m)), reverse=True)
    oracle = block.exact_rank
    lower_set, lower_exact = empty, True
    for mask in candidates:
        if not mask.any():
            break  # the empty set: rank 0 < L
        rank = oracle(space.slots(mask)) if oracle is not None else None
        if rank is None:
            lower_set, lower_exact = mask, False
            break
        if rank < space.n_columns:
            lower_set = mask
            break
    up = None if found.lower is None else tuple(int(m) for m in found.lower)
    upper = Fraction(1) if up is None else value(up)
    return SigmaBracket(
        phases=N0,
        lower=value(misses(lower_set)),
        upper=upper,
        lower_set=tuple((int(n), int(g)) for n, g in space.slots(lower_set)),
        lower_misses=misses(lower_set),
        upper_misses=up,
        lower_exact=lower_exact,
        found=tuple(misses(m) for m in found.masks),
    )


def compute_sigma(
    block: PhaseBlock,
    channels: Sequence[MarkovChannel],
    budget: Budget | None = None,
    *,
    memo: Memo | None = None,
) -> SigmaResult:
    """``sigma_k`` of a reduced FMO block (Rohr, Marelli and Fu (2014), Lemmas 2-3, Corollary 2).

    .. math::

        \\sigma = \\max_{F\\ \\text{maximal blind}} \\rho(M_F), \\qquad
        \\rho(M_F)^N = \\rho(P_F) = \\prod_g \\rho(P_{F,g}).

    Routes: a fully blind block has ``sigma = 1``; a non-degenerate block with
    one packet has only the empty blind set, ``sigma = P(g = 0 | nu zeros)``
    (Lemma 2); otherwise maximal blind sets are closures
    (:mod:`kfio.search._blind`).  With one packet a branch and bound finds the
    worst one (for Bernoulli the largest, Corollary 2); with several Bernoulli
    packets a Pareto branch and bound finds one set per undominated miss
    vector (:mod:`kfio.search._pareto`), which is all that ``sigma`` and
    the exact stability regions depend on; with a Markov packet among several
    every shift orbit is enumerated.

    Parameters
    ----------
    block:
        The reduced FMO block in phase form.
    channels:
        ``channels[g]`` is the channel of row group ``g``; groups are
        independent.
    budget:
        Work budget; ``None`` allows :data:`DEFAULT_MAX_STEPS` steps.
    memo:
        A dict the caller keeps for this ``block`` (and no other) across
        calls with different channels: the rank tests, the blind sets of every
        route whose search does not depend on the probabilities (see
        :func:`_route`; for Bernoulli packets the exponents ``z_g / N`` and the
        Pareto front, Corollary 2) and the exact rank checks of each worst set
        are kept in it, so a later call evaluates only the closed form
        ``sigma = prod_g (1 - lambda_g)^(z_g / N)`` (and, on a front, its
        argmax).  The result equals the one without ``memo``; only finished
        work is kept (a search cut short by its budget leaves nothing).

    Returns
    -------
    SigmaResult

    Raises
    ------
    InvalidInput
        Wrong number of channels, or a block without columns.
    AssumptionViolation
        An arrival probability of 0 or 1 (Rohr, Marelli and Fu (2014), Assumption 1).
    BudgetExceeded
        The closure search or the exact checks need more than ``budget``;
        :class:`SigmaBudgetExceeded` (with the bracket proved so far) when the
        search over several Bernoulli sensors was cut short.
    NumericalFailure
        Exact arithmetic contradicts a numerical rank decision.

    Examples
    --------
    Rohr, Marelli and Fu (2014), Example 3: ``A = alpha diag(1, -1)``, ``C = [1 1]``, i.i.d.
    arrivals with ``lambda = 3/4``: ``sigma = (1 - lambda)^(1/2)``.

    >>> blk = PhaseBlock(2, (0, 1), np.array([[1.0, 1.0]]), ((0,),))
    >>> ch = MarkovChannel("bernoulli", 0, (Fraction(3, 4),))
    >>> res = compute_sigma(blk, [ch])
    >>> res.sigma, res.bernoulli_exponents, sorted(res.worst_blind_set)
    (0.5, (Fraction(1, 2),), [(0, 0)])
    >>> abs(res.sigma**2 - 0.25) < 1e-15  # substitute back: sigma^2 = 1 - lambda
    True
    """
    memo = memo if memo is not None else {}
    _check_inputs(block, channels, memo)
    budget = budget if budget is not None else Budget(max_steps=DEFAULT_MAX_STEPS)
    period = sigma_period(block.base_period, channels)
    if "ranks" not in memo:  # the block alone: its slots and the two rank tests
        space = SlotSpace.from_block(block)
        margins = Margins(space.tol)
        L = space.n_columns
        fully_blind = space.rank(np.ones(space.size, dtype=bool), margins) < L
        phase0 = space.mask([(0, g) for g in range(space.n_groups)])
        degenerate = space.rank(phase0, margins) < L
        memo["ranks"] = (space, dataclasses.replace(margins), fully_blind, phase0, degenerate)
    space, kept, fully_blind, phase0, degenerate = memo["ranks"]
    margins = dataclasses.replace(kept)
    route = _route(space, channels, degenerate, fully_blind)
    if route is not None and route in memo:
        found, kept = memo[route]
        margins = dataclasses.replace(kept)
        if route in ("pareto", "orbits"):  # the front is kept; the worst set on it depends on the channels
            found = dataclasses.replace(found, worst=_pick_worst(found.maximal, channels, space.n_phases, period))
    else:
        try:
            found = _find_worst(space, block.exponents, channels, period, degenerate, fully_blind, budget, margins)
        except FrontBudgetExceeded as exc:
            raise SigmaBudgetExceeded(str(exc), sigma_bracket(block, space, channels, exc.found)) from exc
        if route is not None:
            memo[route] = (found, dataclasses.replace(margins))
    bernoulli = all(ch.order == 0 for ch in channels)
    checked = (route, bernoulli, period, found.worst.tobytes()) if route is not None else None
    if checked is None or checked not in memo:
        # The exact checks, the shares z_g / N and the lifted sets depend on the sets, the period and
        # whether every channel is Bernoulli: never on a probability.
        exponents = _unblind_shares(space, found.worst, channels)
        certified, cert_note = _certify(
            block, _exact_checks(space, found, margins, phase0, degenerate, bernoulli), budget
        )
        lifted = (
            _lift(space, found.worst, period),
            tuple(_lift(space, m, period) for m in found.maximal) if found.enumerated else (),
        )
        kept_checks = (exponents, certified, cert_note, _margin_note(margins), lifted)
        if checked is not None:
            memo[checked] = kept_checks
    else:
        kept_checks = memo[checked]
    exponents, certified, cert_note, margin_note, (worst_lifted, maximal_lifted) = kept_checks
    sigma, rho = _sigma_values(space, found, channels, period, exponents)
    notes = [found.method, cert_note, margin_note]
    return SigmaResult(
        period=period,
        sigma=sigma,
        rho_period=rho,
        degenerate=degenerate,
        fully_blind=fully_blind,
        worst_blind_set=worst_lifted,
        maximal_blind_sets=maximal_lifted,
        bernoulli_exponents=exponents,
        certified=certified,
        notes=tuple(notes),
    )


def _margin_note(margins: Margins) -> str:
    text = (
        f"numerical rank threshold {margins.tol:.1e}: values treated as zero <= {margins.largest_zero:.1e}, "
        f"as non-zero >= {margins.smallest_nonzero:.1e}"
    )
    return text if margins.clear else text + " (close call: trust only the exact confirmation)"


__all__ = [
    "DEFAULT_MAX_STEPS",
    "SigmaBracket",
    "SigmaBudgetExceeded",
    "SigmaResult",
    "compute_sigma",
    "period_transfer_matrix",
    "sigma_period",
]
