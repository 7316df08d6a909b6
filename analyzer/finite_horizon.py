"""Exact finite-horizon ``E[P_t]`` by enumerating every arrival sequence.

Seed 001, eq. (7):

.. math::

    \\mathbb{E}[P_t] = \\sum_{S \\in \\mathbb{B}^t} \\mathbb{P}(\\Gamma_t = S)\\, \\Psi(P_0, S),

with ``Psi(P_0, S) = Phi_{S(t)} o ... o Phi_{S(1)}(P_0)`` (eqs. (4)-(5)) and
``Phi_0``, ``Phi_1`` the open-loop and measurement updates of eq. (2).  With
``m`` packets each step has ``2^m`` arrival patterns and ``Phi_S`` uses the
rows of the packets in ``S`` (MATH.md section 1).

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

from .budget import Budget
from .errors import InvalidInput, LimitExceeded
from .model import Request
from .sim_channel import JointChannel
from .sim_kernel import RiccatiStep
from .sim_setup import (
    DEFAULT_SIMULATION_LIMITS,
    OPTIONS_FIELD,
    SimSystem,
    SimulationLimits,
    check_exact_steps,
    finite_or_none,
    matrix_or_none,
    parse_options,
    sim_system,
)

#: Cap on the floats of one batch of children (32 MiB of covariances).
_CHUNK_FLOATS = 1 << 22


@dataclass(frozen=True, eq=False)
class FiniteHorizonReport:
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
        ``(T + 1, n, n)``; NaN from the first step at which float64 overflowed.
    """

    steps: int
    sequences: int
    initial_channel: str
    P0: np.ndarray
    mean_covariance: np.ndarray

    @property
    def mean_trace(self) -> np.ndarray:
        """``trace(E[P_t])`` for ``t = 0..T`` (NaN after divergence)."""
        return np.einsum("tii->t", self.mean_covariance)

    @property
    def diverged_at(self) -> int | None:
        """First ``t`` whose ``E[P_t]`` overflowed float64, or ``None``."""
        bad = np.flatnonzero(~np.isfinite(self.mean_covariance).all(axis=(1, 2)))
        return int(bad[0]) if bad.size else None

    def growth_per_step(self, window: int | None = None) -> float | None:
        """``exp`` of the least-squares slope of ``log trace E[P_t]`` over the last ``window + 1`` steps.

        For an unstable system this estimates ``max_k |alpha_k|^2 sigma_k``
        (seed 001, Theorem 1); a stable one levels off at 1.  ``window``
        defaults to half the horizon.  ``None`` if the trace is not finite
        and positive over the window, or the horizon is shorter than 2.
        """
        return log_slope_growth(self.mean_trace, window)

    def to_dict(self) -> dict[str, Any]:
        growth = self.growth_per_step()
        last_ok = self.mean_covariance[-1]
        return {
            "steps": self.steps,
            "sequences": self.sequences,
            "initial_channel": self.initial_channel,
            "mean_trace": [finite_or_none(x) for x in self.mean_trace],
            "final_mean_covariance": matrix_or_none(last_ok),
            "diverged": self.diverged_at is not None,
            "diverged_at": self.diverged_at,
            "growth_per_step": None if growth is None else finite_or_none(growth),
        }

    def summary(self) -> str:
        lines = [
            f"Exact E[P_t] over {self.sequences} arrival sequences (t = 0..{self.steps}, "
            f"channel history at t = 0: {self.initial_channel})",
            "   t   trace E[P_t]",
        ]
        for t, x in enumerate(self.mean_trace):
            lines.append(f"{t:4d}   {x:.6g}" if math.isfinite(x) else f"{t:4d}   diverged (float64 overflow)")
        growth = self.growth_per_step()
        if growth is not None:
            lines.append(f"growth per step over the second half: x{growth:.4g}")
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
    P: np.ndarray,
    w: np.ndarray,
    hist: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """All one-step extensions of a batch: ``Phi_g`` for each pattern ``g``."""
    Ps, ws, hs = [], [], []
    for g, phi in steps:
        wg = w * chan.pattern_probability(hist, g)
        keep = wg.sum(axis=1) > 0
        if not keep.any():
            continue
        Ps.append(phi(P[keep]))
        ws.append(wg[keep])
        hs.append(chan.advance(hist[keep], np.broadcast_to(np.array(g), hist[keep].shape)))
    return np.concatenate(Ps), np.concatenate(ws), np.concatenate(hs)


def enumerate_expectation(
    sim: SimSystem,
    P0: np.ndarray,
    steps: int,
    initial_channel: str = "stationary",
    budget: Budget | None = None,
) -> np.ndarray:
    """``E[P_t]`` for ``t = 0..steps`` as a ``(steps + 1, n, n)`` array.

    The low-level route (no option parsing, no limits): ``sim`` and ``P0``
    as arrays.  With a Bernoulli channel, ``enumerate_expectation(sim, X,
    N)[N]`` is seed 002's ``g_N(X)``.
    """
    chan = JointChannel.from_packets(sim.packets)
    hist0, w0 = chan.initial_distribution(initial_channel)
    n = sim.n
    collapse_at = max(chan.orders, default=0)
    chunk = max(1, _CHUNK_FLOATS // (n * n * (1 << chan.m)))
    phis = _pattern_steps(sim, chan)
    sums = np.zeros((steps + 1, n, n))
    stack = [(0, np.asarray(P0, dtype=float)[None].copy(), w0[None, :], hist0[None, :, :])]
    with np.errstate(all="ignore"):
        while stack:
            t, P, w, hist = stack.pop()
            sums[t] += np.einsum("k,kij->ij", w.sum(axis=1), P)
            if t == steps:
                continue
            if budget is not None:
                budget.tick("exact enumeration of E[P_t]", len(P) << chan.m)
            P, w, hist = _expand(phis, chan, P, w, hist)
            if t + 1 >= collapse_at and w.shape[1] > 1:
                w, hist = w.sum(axis=1, keepdims=True), hist[:, :1]
            for start in range(0, len(P), chunk):
                sl = slice(start, start + chunk)
                stack.append((t + 1, P[sl], w[sl], hist[sl]))
    bad = ~np.isfinite(sums).all(axis=(1, 2))
    if bad.any():
        sums[int(np.flatnonzero(bad)[0]) :] = np.nan
    return sums


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

    >>> from analyzer import load_request
    >>> req = load_request('{"system": {"A": [[2]], "C": [[1]], "Q": [[1]], "R": [[1]]},'
    ...                    ' "channel": {"model": "bernoulli", "arrival_probability": 0.5}}')
    >>> float(expected_covariance(req, 1).mean_trace[1])
    4.0
    """
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 0:
        raise InvalidInput(f"{OPTIONS_FIELD}/exact_steps", f"the horizon must be a non-negative integer; got {steps!r}")
    sim = sim_system(request)
    opts = parse_options(request, limits)
    _check_enumeration_size(sim, steps, opts.initial_channel, limits)
    if budget is None and request.time_budget_s is not None:
        budget = Budget(seconds=request.time_budget_s)
    chan = JointChannel.from_packets(sim.packets)
    means = enumerate_expectation(sim, opts.P0, steps, opts.initial_channel, budget)
    means.setflags(write=False)
    return FiniteHorizonReport(
        steps=steps,
        sequences=1 << (chan.m * steps),
        initial_channel=opts.initial_channel,
        P0=opts.P0,
        mean_covariance=means,
    )
