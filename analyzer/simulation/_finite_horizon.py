"""Exact finite-horizon ``E[P_t]`` by enumerating every arrival sequence.

Rohr, Marelli and Fu (2014), eq. (7):

.. math::

    \\mathbb{E}[P_t] = \\sum_{S \\in \\mathbb{B}^t} \\mathbb{P}(\\Gamma_t = S)\\, \\Psi(P_0, S),

with ``Psi(P_0, S) = Phi_{S(t)} o ... o Phi_{S(1)}(P_0)`` (eqs. (4)-(5)) and
``Phi_0``, ``Phi_1`` the open-loop and measurement updates of eq. (2).  With
``m`` packets each step has ``2^m`` arrival patterns and ``Phi_S`` uses the
rows of the packets in ``S`` (docs/theory.md).

Algorithm
---------
Level by level, on batches.  A batch holds ``K`` sequences of the same
length ``t``: their covariances ``Psi(P_0, S)`` ``(K, n, n)``, and for each
initial channel history ``h_0`` the joint probability
``P(Gamma_t = S, h_0)`` and the channel history reached ``(K, H, m)``.  The
covariance depends on ``S`` only, so it is computed once per sequence,
whatever the initial history.  One level expands every pattern ``g`` with one
batched Riccati update (all sequences of the batch share ``C_S``), multiplies
the weights by ``P(g | h)`` and shifts the histories.  After ``max(nu)``
steps the history is a function of ``S`` alone, and the ``H`` weight columns
are summed into one.  Batches whose children would exceed a memory cap are
split and descended depth-first, so memory stays bounded while every Riccati
update still runs on a whole batch.

Identical matrices are not merged: for generic systems distinct sequences give
distinct covariances, and finding duplicates would cost a sort per level.
Sequences of probability zero (possible when a channel probability is 0 or 1)
are dropped, which is exact.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._budget import Budget
from .._reporting import Report
from ..errors import InvalidInput, LimitExceeded
from ..model import Request, value_text
from ._channel import JointChannel
from ._filtered import filtered_covariance
from ._kernel import PRECISION_RATIO, RiccatiStep
from ._setup import (
    DEFAULT_SIMULATION_LIMITS,
    OPTIONS_FIELD,
    SimSystem,
    SimulationLimits,
    check_exact_steps,
    parse_options,
    sim_system,
)

#: Cap on the floats of one batch of children (32 MiB of covariances).
_CHUNK_FLOATS = 1 << 22


@dataclass(frozen=True, eq=False, repr=False)
class FiniteHorizonReport(Report):
    """``E[P_t]`` for ``t = 0..steps``, exactly up to float rounding.

    Attributes
    ----------
    steps:
        Horizon ``T``.
    sequences:
        ``2^(m T)``, the arrival sequences summed over at the last level.
    initial_channel:
        How the channel histories before ``t = 0`` were distributed.
    P0:
        The initial covariance.
    mean_covariance:
        ``(T + 1, n, n)``: the predictor ``E[P(t|t-1)]``; NaN from the first
        step at which float64 overflowed.
    filtered_mean_covariance:
        ``(T + 1, n, n)``: the filtered ``E[P(t|t)]`` over the same sequences.
    imprecise_probability:
        ``(T + 1,)``: probability of the sequences that went through a
        measurement update beyond :data:`kfio.simulation._kernel.PRECISION_RATIO`
        (see :func:`enumerate_expectation`); 0 in all but strongly unstable
        cases.
    """

    steps: int
    sequences: int
    initial_channel: str
    P0: np.ndarray
    mean_covariance: np.ndarray
    imprecise_probability: np.ndarray
    filtered_mean_covariance: np.ndarray | None = None

    @property
    def filtered_mean_trace(self) -> np.ndarray | None:
        """``trace(E[P(t|t)])`` for ``t = 0..T`` (NaN after divergence), or ``None``."""
        f = self.filtered_mean_covariance
        return None if f is None else np.einsum("tii->t", f)

    @property
    def mean_trace(self) -> np.ndarray:
        """``trace(E[P_t])`` for ``t = 0..T`` (NaN after divergence)."""
        result: np.ndarray = np.einsum("tii->t", self.mean_covariance)
        return result

    @property
    def diverged_at(self) -> int | None:
        """First ``t`` whose ``E[P_t]`` overflowed float64, or ``None``."""
        bad = np.flatnonzero(~np.isfinite(self.mean_covariance).all(axis=(1, 2)))
        return int(bad[0]) if bad.size else None

    def growth_per_step(self, window: int | None = None) -> float | None:
        """``exp`` of the least-squares slope of ``log trace E[P_t]`` over the last ``window + 1`` steps.

        For an unstable system this estimates ``max_k |alpha_k|^2 sigma_k``
        (Rohr, Marelli and Fu (2014), Theorem 1); a stable one levels off at 1.  ``window``
        defaults to half the horizon.  ``None`` if the trace is not finite
        and positive over the window, or the horizon is shorter than 2.
        """
        return log_slope_growth(self.mean_trace, window)

    def _repr_items(self) -> list[tuple[str, Any]]:
        return [
            ("steps", self.steps),
            ("sequences", self.sequences),
            ("final_mean_trace", float(self.mean_trace[-1])),
            ("diverged_at", self.diverged_at),
        ]

    def summary(self) -> str:
        lines = [
            f"Exact E[P_t] over {self.sequences} arrival sequences (t = 0..{self.steps}, "
            f"channel history at t = 0: {self.initial_channel})",
            "   t   trace E[P(t|t-1)]   trace E[P(t|t)]",
        ]
        ftr = self.filtered_mean_trace
        for t, x in enumerate(self.mean_trace):
            f = f"   {ftr[t]:15.6g}" if ftr is not None and math.isfinite(ftr[t]) else ""
            lines.append(f"{t:4d}   {x:17.6g}{f}" if math.isfinite(x) else f"{t:4d}   diverged (float64 overflow)")
        growth = self.growth_per_step()
        if growth is not None:
            lines.append(f"growth per step over the second half: x{growth:.4g}")
        if self.imprecise_probability[-1] > 0:
            lines.append(
                f"sequences of total probability {self.imprecise_probability[-1]:.3g} went through an update "
                "beyond float64's faithful precision (innovation ratio > 1e12)"
            )
        return "\n".join(lines)


def log_slope_growth(trace: np.ndarray, window: int | None = None) -> float | None:
    """``exp(slope)`` of a least-squares line through ``log trace[-window-1:]``."""
    T = len(trace) - 1
    w = max(T // 2, 1) if window is None else window
    if T < 2 or w < 1 or w > T:
        return None
    y = np.asarray(trace[T - w :], dtype=float)
    if not np.all(np.isfinite(y)) or np.any(y <= 0):
        return None
    slope = np.polyfit(np.arange(w + 1, dtype=float), np.log(y), 1)[0]
    return float(np.exp(slope))


def _pattern_steps(sim: SimSystem, chan: JointChannel) -> list[tuple[tuple[bool, ...], RiccatiStep]]:
    """``Phi_g`` for each arrival pattern ``g``, with the rows ``C_S`` of its packets."""
    out = []
    for g in chan.patterns():
        rows = list(sim.rows_of(g))
        out.append((g, RiccatiStep.build(sim.A, sim.Q, sim.C[rows], sim.R[np.ix_(rows, rows)])))
    return out


def _expand(
    steps: list[tuple[tuple[bool, ...], RiccatiStep]],
    chan: JointChannel,
    batch: _Batch,
) -> _Batch:
    """All one-step extensions of a batch: ``Phi_g`` for each pattern ``g``."""
    parts = []
    for g, phi in steps:
        wg = batch.w * chan.pattern_probability(batch.hist, g)
        keep = wg.sum(axis=1) > 0
        if not keep.any():
            continue
        Pg, ratio = phi.apply(batch.P[keep])
        hist = batch.hist[keep]
        parts.append(
            _Batch(
                Pg,
                wg[keep],
                chan.advance(hist, np.broadcast_to(np.array(g), hist.shape)),
                batch.imprecise[keep] | (ratio > PRECISION_RATIO),
            )
        )
    return _Batch(*(np.concatenate([getattr(b, f) for b in parts]) for f in ("P", "w", "hist", "imprecise")))


@dataclass(frozen=True, eq=False)
class _Batch:
    """Sequences of one length: covariances, weights per initial history, histories, precision flags."""

    P: np.ndarray  # (K, n, n)
    w: np.ndarray  # (K, H): P(Gamma_t = S, h_0)
    hist: np.ndarray  # (K, H, m): channel history reached from h_0
    imprecise: np.ndarray  # (K,): went through an update beyond PRECISION_RATIO

    def __len__(self) -> int:
        return len(self.P)

    def collapse(self) -> _Batch:
        """Sum the initial-history columns (valid once histories no longer depend on ``h_0``)."""
        return _Batch(self.P, self.w.sum(axis=1, keepdims=True), self.hist[:, :1], self.imprecise)

    def chunks(self, size: int) -> list[_Batch]:
        return [
            _Batch(self.P[i : i + size], self.w[i : i + size], self.hist[i : i + size], self.imprecise[i : i + size])
            for i in range(0, len(self), size)
        ]


def enumerate_expectation(
    sim: SimSystem,
    P0: np.ndarray,
    steps: int,
    initial_channel: str = "stationary",
    budget: Budget | None = None,
    filtered_out: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """``E[P_t]`` for ``t = 0..steps``, and the probability of imprecise sequences.

    If ``filtered_out`` (shape ``(steps + 1, n, n)``, zeros) is given, it
    receives the exact filtered mean ``E[P(t|t)] = sum_S P(Gamma_t = S, g_t = g)
    (P_S - P_S C_g'(C_g P_S C_g' + R_gg)^-1 C_g P_S)`` over the same sequences
    and the arrival pattern ``g`` at ``t`` (:mod:`kfio.simulation._filtered`).

    The low-level route (no option parsing, no limits): ``sim`` and ``P0``
    as arrays.  With a Bernoulli channel, ``enumerate_expectation(sim, X,
    N)[0][N]`` is Rohr, Marelli and Fu (2010)'s ``g_N(X)``.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        ``(steps + 1, n, n)`` means (NaN from the first level that overflowed)
        and ``(steps + 1,)`` the probability that ``Gamma_t`` went through a
        measurement update beyond :data:`kfio.simulation._kernel.PRECISION_RATIO`.
        Such a sequence's covariance is not faithful in float64, but it stays
        bounded by its open-loop sibling (``0 <= Phi_S(P) <= Phi_0(P)``), whose
        weight is comparable, so the mean keeps its accuracy unless that
        probability is large.
    """
    chan = JointChannel.from_packets(sim.packets)
    hist0, w0 = chan.initial_distribution(initial_channel)
    n = sim.n
    collapse_at = max(chan.orders, default=0)
    chunk = max(1, _CHUNK_FLOATS // (n * n * (1 << chan.m)))
    phis = _pattern_steps(sim, chan)
    sums = np.zeros((steps + 1, n, n))
    imprecise = np.zeros(steps + 1)
    first = _Batch(np.asarray(P0, dtype=float)[None].copy(), w0[None, :], hist0[None, :, :], np.zeros(1, dtype=bool))
    stack = [(0, first)]
    with np.errstate(all="ignore"):
        while stack:
            t, batch = stack.pop()
            weights = batch.w.sum(axis=1)
            sums[t] += np.einsum("k,kij->ij", weights, batch.P)
            imprecise[t] += weights[batch.imprecise].sum()
            if filtered_out is not None:
                for g in chan.patterns():
                    wg = (batch.w * chan.pattern_probability(batch.hist, g)).sum(axis=1)
                    mask = np.broadcast_to(sim.row_mask(np.array(g, dtype=float)), (len(batch), sim.C.shape[0]))
                    filtered_out[t] += np.einsum("k,kij->ij", wg, filtered_covariance(batch.P, sim.C, sim.R, mask))
            if t == steps:
                continue
            if budget is not None:
                budget.tick("exact enumeration of E[P_t]", len(batch) << chan.m)
            children = _expand(phis, chan, batch)
            if t + 1 >= collapse_at and children.w.shape[1] > 1:
                children = children.collapse()
            stack.extend((t + 1, c) for c in children.chunks(chunk))
    for arr in (sums,) if filtered_out is None else (sums, filtered_out):
        bad = ~np.isfinite(arr).all(axis=(1, 2))
        if bad.any():
            arr[int(np.flatnonzero(bad)[0]) :] = np.nan
    return sums, imprecise


def _check_enumeration_size(sim: SimSystem, steps: int, initial: str, limits: SimulationLimits) -> None:
    chan = JointChannel.from_packets(sim.packets)
    check_exact_steps(steps, chan.m, limits, f"{OPTIONS_FIELD}/exact_steps")
    peak = chan.initial_count(initial) << (chan.m * min(steps, max(chan.orders, default=0)))
    if peak > limits.max_sequences:
        raise LimitExceeded(
            f"{OPTIONS_FIELD}/initial_channel",
            f"the stationary start spreads over {chan.initial_count(initial)} channel histories, which with "
            f"{steps} steps means {peak} weights (limit {limits.max_sequences}); "
            "use initial_channel 'all_lost' or 'all_arrived'",
        )


def expected_covariance(
    request: Request,
    steps: int,
    budget: Budget | None = None,
    limits: SimulationLimits = DEFAULT_SIMULATION_LIMITS,
) -> FiniteHorizonReport:
    """Exact ``E[P_t]``, ``t = 0..steps``, for any Markov or per-sensor channel.

    Parameters
    ----------
    request:
        A validated request with ``Q`` and ``R``.  ``P0`` and
        ``initial_channel`` are read from ``options.simulate`` (defaults
        ``Q`` and ``"stationary"``).
    steps:
        Horizon ``T >= 0``; ``2^(m T)`` must not exceed
        ``limits.max_sequences`` (``m`` packets).
    budget:
        Optional work budget; the enumeration ticks once per batch.

    Returns
    -------
    FiniteHorizonReport

    Raises
    ------
    InvalidInput
        ``Q`` or ``R`` missing, invalid options, ``steps`` not a non-negative
        integer.
    LimitExceeded
        Too many sequences (field ``/options/simulate/exact_steps``).
    BudgetExceeded
        The budget ran out.

    Examples
    --------
    Scalar ``a = 2``, Bernoulli ``lambda = 1/2``, ``P_0 = Q = 1``, ``R = 1``:
    ``E[P_1] = (1/2)(4 + 1) + (1/2)(4 - 4/2 + 1) = 4``.

    >>> from kfio import load_request
    >>> req = load_request('{"system": {"A": [[2]], "C": [[1]], "Q": [[1]], "R": [[1]]},'
    ...                    ' "channel": {"model": "bernoulli", "arrival_probability": 0.5}}')
    >>> float(expected_covariance(req, 1).mean_trace[1])
    4.0
    """
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 0:
        raise InvalidInput(
            f"{OPTIONS_FIELD}/exact_steps", f"the horizon must be a non-negative integer; got {value_text(steps)}"
        )
    sim = sim_system(request)
    opts = parse_options(request, limits)
    _check_enumeration_size(sim, steps, opts.initial_channel, limits)
    if budget is None and request.time_budget_s is not None:
        budget = Budget(seconds=request.time_budget_s)
    chan = JointChannel.from_packets(sim.packets)
    filtered = np.zeros((steps + 1, sim.n, sim.n))
    means, imprecise = enumerate_expectation(sim, opts.P0, steps, opts.initial_channel, budget, filtered)
    means.setflags(write=False)
    imprecise.setflags(write=False)
    filtered.setflags(write=False)
    return FiniteHorizonReport(
        steps=steps,
        sequences=1 << (chan.m * steps),
        initial_channel=opts.initial_channel,
        P0=opts.P0,
        mean_covariance=means,
        imprecise_probability=imprecise,
        filtered_mean_covariance=filtered,
    )
