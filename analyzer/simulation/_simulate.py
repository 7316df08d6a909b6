"""Monte Carlo simulation of the stochastic Riccati recursion.

Rohr, Marelli and Fu (2014), eqs. (2)-(5): ``P_{t+1} = Phi_{g_t}(P_t)`` where ``g_t`` is the
(random) arrival of the packets sent at ``t``; with several packets
``Phi_S`` uses the rows of the packets in ``S`` (docs/theory.md).  We draw
``M`` independent arrival processes from the request's channel and propagate
``M`` covariances at once, as the ``(n(n+1)/2, M)`` unique entries
(:class:`kfio.simulation._packed.PackedRiccatiStep`, which also gives the
filtered ``trace P(t|t)`` of the same arrivals in the same pass).  At every ``t = 0..T`` we
record statistics of ``trace(P_t)`` over the trajectories: the mean with a
95% confidence band (normal approximation, ``mean +- 1.96 s / sqrt(M)``) and
the 50th, 90th and 99th percentiles.

Channel histories before ``t = 0`` follow ``options.simulate.
initial_channel`` (default: the stationary distribution, see
:mod:`kfio.simulation._setup`).  The generator is ``numpy.random.Generator(
PCG64(seed))``: the same request and seed give the same report.

Overflow.  A trajectory whose trace exceeds
:data:`kfio.simulation._kernel.DIVERGENCE_TRACE` (or turns non-finite), or whose
measurement update has an innovation ratio above
:data:`kfio.simulation._kernel.PRECISION_RATIO` (float64 can no longer carry its
posterior), is marked diverged and counts as ``+inf`` from then on.  In a
stable regime neither happens in practice: the chance that a trajectory
reaches a ratio ``X`` decays like a power of ``X`` above 1.  The mean is reported as
``null`` from the first step at which any trajectory diverged
(``mean_diverged_at``); a percentile is ``null`` once more than its tail of
trajectories diverged.

The confidence band is only as good as the central limit theorem: when
``trace(P_t)`` is heavy-tailed (near or past the stability threshold) the
sample mean is dominated by rare trajectories and the band is too narrow;
read the percentiles, and use :mod:`kfio.simulation._finite_horizon` for exact means
at short horizons.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._budget import Budget
from .._json import json_float
from .._reporting import Report
from ..model import Request
from ._channel import JointChannel
from ._finite_horizon import FiniteHorizonReport, expected_covariance
from ._kernel import DIVERGENCE_TRACE, PRECISION_RATIO, GroupedRiccatiStep, RiccatiStep, healthy, traces
from ._order import order_indices
from ._outage_target import outage_target, parse_outage_target
from ._packed import PackedRiccatiStep
from ._setup import (
    DEFAULT_SIMULATION_LIMITS,
    PERCENTILES,
    SimSystem,
    SimulateOptions,
    SimulationLimits,
    parse_options,
    sim_system,
)
from ._stationary import Z95, StationaryReport, parse_thresholds, stationary_report, verdict_headline
from ._step_stats import TraceRecorder

#: Seconds the simulation may spend on Theorem 1's report (tail exponent, growth rate) before going without it.
EXACT_ANALYSIS_S = 5.0

#: A step's band has zero width when its standard error is at most this fraction of the value: every
#: trajectory had the same ``P_t`` and what is left is the rounding of the sums over trajectories.
DETERMINISTIC_SEM = 1e-12
#: At such a step the Monte Carlo mean equals the exact value when within this relative distance.
DETERMINISTIC_TOL = 1e-9

#: Two-sided 95% quantile of the standard normal distribution.


@dataclass(frozen=True, eq=False)
class TraceStatistics:
    """Per-step statistics of ``trace(P_t)``, ``t = 0..T`` (NaN where undefined)."""

    mean: np.ndarray
    std: np.ndarray
    percentiles: np.ndarray  # (len(PERCENTILES), T + 1); +inf where the percentile diverged
    diverged: np.ndarray  # (T + 1,) trajectories diverged by t
    trajectories: int

    @property
    def sem(self) -> np.ndarray:
        """Standard error of the mean."""
        return self.std / math.sqrt(self.trajectories)


@dataclass(frozen=True, eq=False)
class MonteCarloRun:
    """Raw output of :func:`run_monte_carlo`."""

    stats: TraceStatistics
    final_mean_covariance: np.ndarray | None
    arrival_rate: np.ndarray  # empirical, per packet
    final_traces: np.ndarray | None = None  # trace(P_T) per trajectory, +inf where diverged
    filtered_stats: TraceStatistics | None = None  # the same statistics of trace(P(t|t))
    final_mean_filtered_covariance: np.ndarray | None = None
    final_filtered_traces: np.ndarray | None = None


@dataclass(frozen=True, eq=False, repr=False)
class SimulationReport(Report):
    """What ``kfio simulate`` reports.

    Attributes
    ----------
    options:
        The validated options (steps, trajectories, seed, P0, ...).
    stats:
        Per-step statistics of ``trace(P_t)``.
    final_mean_covariance:
        Sample mean of the predictor ``P_T = P(T|T-1)``; ``None`` if a trajectory diverged.
    filtered_stats, final_mean_filtered_covariance:
        The same for the filtered ``P(t|t)`` (:mod:`kfio.simulation._filtered`),
        computed per trajectory from the predictor and the same arrivals.
    arrival_rate, stationary_arrival_rate:
        Observed and long-run fraction of arrivals per packet (a check on the
        channel sampler).
    packet_names:
        Packet names (``""`` for the one-packet case).
    exact:
        Exact ``E[P_t]`` (Rohr, Marelli and Fu (2014), eq. (7)) when ``exact_steps`` was asked.
    """

    options: SimulateOptions
    stats: TraceStatistics
    final_mean_covariance: np.ndarray | None
    arrival_rate: np.ndarray
    stationary_arrival_rate: np.ndarray
    packet_names: tuple[str, ...]
    exact: FiniteHorizonReport | None = None
    stationary: StationaryReport | None = None
    filtered_stats: TraceStatistics | None = None
    final_mean_filtered_covariance: np.ndarray | None = None
    outage_target: Any = None  # kfio.simulation._outage_target.OutageTarget when asked

    @property
    def mean_trace(self) -> np.ndarray:
        return self.stats.mean

    @property
    def ci95(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper 95% band of the mean (normal approximation).

        The lower end is clipped at 0, since ``trace(P_t) >= 0``.
        """
        half = Z95 * self.stats.sem
        return np.maximum(self.stats.mean - half, 0.0), self.stats.mean + half

    def percentile(self, q: int) -> np.ndarray:
        """The ``q``-th percentile of ``trace(P_t)`` over time (``+inf`` where diverged)."""
        result: np.ndarray = self.stats.percentiles[PERCENTILES.index(q)]
        return result

    @property
    def mean_diverged_at(self) -> int | None:
        """First ``t`` at which some trajectory had diverged, or ``None``."""
        return _first(self.stats.diverged > 0)

    def exact_agreement(self) -> dict[str, Any] | None:
        """How the Monte Carlo mean compares with the exact ``E[P_t]``.

        ``z_t = (mean_t - E_t) / sem_t`` over the common, finite steps; about
        95% of them should lie within the band if both routes are right.  A step
        whose band has zero width (every trajectory has the same ``P_t``, as at
        ``t = 0`` from a given ``P0``: the standard error is float rounding, at
        most :data:`DETERMINISTIC_SEM` of the value) has no band to be inside:
        it is counted in ``deterministic_steps`` instead, and in
        ``deterministic_equal`` when the mean equals the exact value to
        :data:`DETERMINISTIC_TOL` relative (rounding of the sums); ``within_ci95``
        and ``max_abs_z`` are over the other steps.
        """
        if self.exact is None:
            return None
        k = min(self.exact.steps, self.options.steps)
        exact = self.exact.mean_trace[: k + 1]
        mean, sem = self.stats.mean[: k + 1], self.stats.sem[: k + 1]
        ok = np.isfinite(exact) & np.isfinite(mean)
        diff = np.abs(mean - exact)
        scale = np.maximum(np.abs(exact), np.abs(mean))
        fixed = ok & (sem <= DETERMINISTIC_SEM * scale)
        random = ok & ~fixed
        z = diff[random] / sem[random]
        return {
            "steps_compared": int(ok.sum()),
            "within_ci95": int((z <= Z95).sum()),
            "max_abs_z": json_float(z.max()) if z.size else None,
            "deterministic_steps": int(fixed.sum()),
            "deterministic_equal": int((fixed & (diff <= DETERMINISTIC_TOL * scale)).sum()),
        }

    def headline(self) -> tuple[str, str]:
        """The exact verdict and the Monte Carlo evidence (:func:`kfio.simulation._stationary.verdict_headline`)."""
        st = self.stationary
        return verdict_headline(
            None if st is None else st.verdict,
            None if st is None else st.kappa,
            self.mean_diverged_at,
            self.options.steps,
        )

    def _repr_items(self) -> list[tuple[str, Any]]:
        o = self.options
        st = self.stationary
        return [
            ("exact_verdict", "not computed" if st is None or st.verdict is None else st.verdict),
            ("steps", o.steps),
            ("trajectories", o.trajectories),
            ("seed", o.seed),
            ("final_mean_trace", float(self.stats.mean[-1])),
            ("mean_diverged_at", self.mean_diverged_at),
        ]

    def summary(self) -> str:
        o = self.options
        low, high = self.ci95
        lines = [". ".join(self.headline())]
        lines += [w for w in self.stationary.summary_lines() if w.startswith("warning")] if self.stationary else []
        lines += [
            f"Monte Carlo: {o.trajectories} trajectories x {o.steps} steps, seed {o.seed}, "
            f"channel history at t = 0: {o.initial_channel}, P0 = {'Q' if o.P0_is_default else 'given'}",
            "trace of the predictor P(t|t-1) (the filtered P(t|t) is in the JSON under 'filtered')",
            f"{'t':>6}  {'mean trace(P_t)':>14}  {'95% band':>25}  {'median':>11}  {'90%':>11}  {'99%':>11}",
        ]
        for t in _display_times(o.steps):
            band = f"[{_fmt(low[t])}, {_fmt(high[t])}]"
            lines.append(
                f"{t:6d}  {_fmt(self.stats.mean[t]):>14}  {band:>25}  {_fmt(self.percentile(50)[t]):>11}"
                f"  {_fmt(self.percentile(90)[t]):>11}  {_fmt(self.percentile(99)[t]):>11}"
            )
        if self.mean_diverged_at is not None:
            lines.append(
                f"the mean diverged at t = {self.mean_diverged_at}: by t = {o.steps}, {int(self.stats.diverged[-1])} of "
                f"{o.trajectories} trajectories left float64's range (trace above 1e150, or an update that "
                "cancels more than 12 digits)"
            )
        agree = self.exact_agreement()
        if agree is not None and self.exact is not None:
            lines.append(agreement_line(agree, self.exact.steps))
        if self.filtered_stats is not None:
            f = self.filtered_stats
            lines.append(
                f"filtered P(t|t) at t = {o.steps}: mean trace {_fmt(f.mean[-1])}, median "
                f"{_fmt(f.percentiles[PERCENTILES.index(50)][-1])}"
            )
        if self.stationary is not None:
            lines.extend(w for w in self.stationary.summary_lines() if not w.startswith("warning"))
        if self.outage_target is not None:
            lines.extend(self.outage_target.summary_lines())
        return "\n".join(lines)


def agreement_line(agree: dict[str, Any], exact_steps: int) -> str:
    """The summary line of :meth:`SimulationReport.exact_agreement`: steps inside the band, zero-width ones apart.

    Examples
    --------
    >>> agreement_line({"steps_compared": 17, "within_ci95": 16, "max_abs_z": 1.9,
    ...                 "deterministic_steps": 1, "deterministic_equal": 1}, 16)
    'exact E[P_t] (t <= 16): inside the 95% band at 16 of 16 random steps (max |z| = 1.9); 1 step with a zero-width band (every trajectory alike) skipped: equal to the exact value'
    """
    fixed = agree.get("deterministic_steps", 0)
    random = agree["steps_compared"] - fixed
    max_z = agree["max_abs_z"]
    line = (
        f"exact E[P_t] (t <= {exact_steps}): inside the 95% band at {agree['within_ci95']} of {random} "
        f"{'random ' if fixed else ''}steps (max |z| = {'n/a' if max_z is None else f'{max_z:.3g}'})"
    )
    if fixed:
        equal = agree.get("deterministic_equal", 0)
        verdict = (
            "equal to the exact value"
            if equal == fixed
            else f"{fixed - equal} of them NOT equal to the exact value (relative difference above 1e-9)"
        )
        steps = "1 step" if fixed == 1 else f"{fixed} steps"
        line += f"; {steps} with a zero-width band (every trajectory alike) skipped: {verdict}"
    return line


def _first(flags: np.ndarray) -> int | None:
    idx = np.flatnonzero(flags)
    return int(idx[0]) if idx.size else None


def _fmt(x: float) -> str:
    return f"{x:.5g}" if math.isfinite(x) else "diverged"


def _display_times(steps: int, rows: int = 10) -> list[int]:
    return sorted({round(k * steps / rows) for k in range(rows + 1)})


def run_monte_carlo(
    sim: SimSystem,
    opts: SimulateOptions,
    budget: Budget | None = None,
    update: PackedRiccatiStep | RiccatiStep | GroupedRiccatiStep | None = None,
    filtered: bool = True,
) -> MonteCarloRun:
    """Propagate ``opts.trajectories`` covariances for ``opts.steps`` steps.

    With ``filtered`` (the default) the statistics of the filtered ``P(t|t)`` of the
    same arrivals are recorded too (``filtered_stats`` and the ``final_*filtered*``
    fields; ``None`` without); the predictor's output is the same either way.

    ``update`` is the batched Riccati step; default the structure-of-arrays
    :class:`kfio.simulation._packed.PackedRiccatiStep` (the benchmark and the
    agreement tests also pass :class:`kfio.simulation._kernel.RiccatiStep`
    and :class:`kfio.simulation._kernel.GroupedRiccatiStep`).  The random
    stream does not depend on the kernel, so seeded runs agree across
    kernels to rounding.
    """
    step = update or PackedRiccatiStep.build(sim.A, sim.Q, sim.C, sim.R)
    rng = np.random.Generator(np.random.PCG64(opts.seed))
    chan = JointChannel.from_packets(sim.packets)
    M, T = opts.trajectories, opts.steps
    hist = chan.sample_initial(opts.initial_channel, M, rng)
    # The packed run keeps only vech(P) (one packed copy of the batch): the full P0 stays a broadcast view.
    P0 = np.broadcast_to(opts.P0, (M, sim.n, sim.n))
    run: _PackedRun | _MatrixRun = (
        _PackedRun(step, P0) if isinstance(step, PackedRiccatiStep) else _MatrixRun(step, P0.copy())
    )
    alive = np.ones(M, dtype=bool)
    recorder = TraceRecorder(M, order_indices(M, np.array(PERCENTILES) / 100.0))
    all_alive, dead = True, 0
    mean, std = np.empty(T + 1), np.empty(T + 1)
    pct = np.empty((len(PERCENTILES), T + 1))
    diverged = np.zeros(T + 1, dtype=np.int64)
    arrivals = np.zeros(chan.m)
    fmean, fstd = np.empty(T + 1), np.empty(T + 1)
    fpct = np.empty((len(PERCENTILES), T + 1))

    memoryless = not any(chan.orders)  # Bernoulli packets: the history stays empty and the probability constant
    constant = chan.arrival_probability(hist[:1]) if memoryless else None

    def draw() -> tuple[np.ndarray, np.ndarray]:
        g = rng.random((M, chan.m)) < (chan.arrival_probability(hist) if constant is None else constant)
        return g, (g.astype(float) if chan.m == 1 else sim.row_mask(g))

    with np.errstate(all="ignore"):
        mean[0], std[0], pct[:, 0] = recorder.record(np.full(M, traces(opts.P0[None])[0]), alive, all_alive)
        for t in range(T):
            if budget is not None:
                budget.tick("Monte Carlo simulation", M)
            g, mask = draw()
            arrivals += g.sum(axis=0)
            ftr, tr, ratio, ok = run.step(mask)  # P(t+1|t), and trace P(t|t) of the same arrivals
            if filtered:
                fmean[t], fstd[t], fpct[:, t] = recorder.record(ftr, alive, all_alive)
            if constant is None:
                hist = chan.advance(hist, g)
            ok &= ratio <= PRECISION_RATIO
            if not (ok.all() if all_alive else ok[alive].all()):
                alive &= ok
                run.freeze(~alive)  # keeps NaN and overflow out of later arithmetic
                dead = M - int(alive.sum())
                all_alive = dead == 0
            diverged[t + 1] = dead
            mean[t + 1], std[t + 1], pct[:, t + 1] = recorder.record(tr, alive, all_alive)
        # The summaries of the last batch (mean matrices, traces), taken on the packed batch:
        # no full (M, n, n) batch is formed.  The arrivals at T are drawn after every draw
        # the predictor used: same seed, same predictor output.
        (final_mean, trP), (final_mean_filtered, ftraces) = run.summaries(draw()[1] if filtered else None, all_alive)
        assert trP is not None
        final_traces = np.where(alive, trP, np.inf)
        if filtered:
            assert ftraces is not None
            final_filtered_traces = np.where(alive, ftraces, np.inf)
            fmean[T], fstd[T], fpct[:, T] = recorder.record(ftraces, alive, all_alive)
    stats = TraceStatistics(mean=mean, std=std, percentiles=pct, diverged=diverged, trajectories=M)
    out = MonteCarloRun(
        stats=stats,
        final_mean_covariance=final_mean,
        arrival_rate=arrivals / (M * T),
        final_traces=final_traces,
    )
    if not filtered:
        return out
    return dataclasses.replace(
        out,
        filtered_stats=TraceStatistics(mean=fmean, std=fstd, percentiles=fpct, diverged=diverged, trajectories=M),
        final_mean_filtered_covariance=final_mean_filtered,
        final_filtered_traces=final_filtered_traces,
    )


#: A batch's mean matrix (``None`` when not taken) and traces (``None`` when not asked).
_Summary = tuple[np.ndarray | None, np.ndarray | None]


class _PackedRun:
    """The packed batch of :func:`run_monte_carlo`, stepped in place by :meth:`PackedRiccatiStep.advance`."""

    def __init__(self, step: PackedRiccatiStep, P0: np.ndarray) -> None:
        self.kernel, self.h, self.work = step, step.pack(P0), step.workspace(len(P0))

    def step(self, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``trace P(t|t)``, ``trace P(t+1|t)``, innovation ratios and health flags (finite, trace bounded)."""
        out = self.kernel.advance(self.h, mask, self.work)
        return out.filtered_trace, out.trace, out.ratio, (out.trace <= DIVERGENCE_TRACE) & out.finite

    def freeze(self, dead: np.ndarray) -> None:
        self.h[:, dead] = 0.0

    def summaries(self, mask: np.ndarray | None, with_mean: bool) -> tuple[_Summary, _Summary]:
        """Mean ``(n, n)`` (if ``with_mean``) and traces of the predictors now, and of their filtered covariances
        for the arrivals ``mask`` (``None``: not asked), from packed batches (the filtered one a second packed copy).
        """
        kernel = self.kernel
        if mask is None:
            return ((kernel.mean(self.h) if with_mean else None), kernel.traces(self.h)), (None, None)
        post = self.h.copy()
        kernel.advance(post, mask, self.work, posterior=True)
        means: list[np.ndarray | None] = list(kernel.means(self.h, post)) if with_mean else [None, None]
        return (means[0], kernel.traces(self.h)), (means[1], kernel.traces(post))


class _MatrixRun:
    """The batch ``(M, n, n)`` of :func:`run_monte_carlo` for the matrix kernels (the references)."""

    def __init__(self, step: RiccatiStep | GroupedRiccatiStep, P0: np.ndarray) -> None:
        self.kernel, self.P = step, P0

    def step(self, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        post, ratio = self.kernel.update(self.P, mask)
        self.P = self.kernel.open_loop(post)
        tr = traces(self.P)
        return traces(post), tr, ratio, healthy(self.P, tr)

    def freeze(self, dead: np.ndarray) -> None:
        self.P[dead] = 0.0

    def summaries(self, mask: np.ndarray | None, with_mean: bool) -> tuple[_Summary, _Summary]:
        pred = (self.P.mean(axis=0) if with_mean else None), traces(self.P)
        if mask is None:
            return pred, (None, None)
        post = self.kernel.update(self.P, mask)[0]
        return pred, ((post.mean(axis=0) if with_mean else None), traces(post))


def simulate(
    request: Request,
    budget: Budget | None = None,
    limits: SimulationLimits = DEFAULT_SIMULATION_LIMITS,
) -> SimulationReport:
    """Monte Carlo statistics of ``trace(P_t)`` (and exact ``E[P_t]`` if asked).

    Parameters
    ----------
    request:
        A validated request with ``Q`` and ``R``; ``options.simulate`` holds
        steps, trajectories, seed, P0, exact_steps and initial_channel (see
        :mod:`kfio.simulation._setup`), ``outage_thresholds`` (see
        :mod:`kfio.simulation._stationary`) and ``outage_target`` (see
        :mod:`kfio.simulation._outage_target`).
    budget:
        Work budget; default: ``request.time_budget_s`` if given.
    limits:
        Size limits (the service passes its own).

    Returns
    -------
    SimulationReport

    Raises
    ------
    InvalidInput
        ``Q``/``R`` missing, invalid options (field under ``/options/simulate``).
    LimitExceeded
        Over ``limits``.
    BudgetExceeded
        The budget ran out.

    Examples
    --------
    >>> from kfio import load_request
    >>> req = load_request('{"system": {"A": [[1.2]], "C": [[1]], "Q": [[1]], "R": [[1]]},'
    ...                    ' "channel": {"model": "bernoulli", "arrival_probability": 0.5},'
    ...                    ' "options": {"simulate": {"steps": 20, "trajectories": 1000, "seed": 1}}}')
    >>> rep = simulate(req)
    >>> rep.mean_trace.shape, rep.mean_diverged_at
    ((21,), None)
    """
    sim = sim_system(request)
    opts = parse_options(request, limits)
    if budget is None and request.time_budget_s is not None:
        budget = Budget(seconds=request.time_budget_s)
    exact = None
    if opts.exact_steps is not None:
        exact = expected_covariance(request, opts.exact_steps, budget, limits)
    thresholds = parse_thresholds(request)
    target_spec = parse_outage_target(request)
    run = run_monte_carlo(sim, opts, budget)
    assert run.final_traces is not None
    stationary = stationary_report(
        run.final_traces, opts.steps, thresholds, _exact_analysis(request), run.final_filtered_traces
    )
    return SimulationReport(
        options=opts,
        stats=run.stats,
        final_mean_covariance=run.final_mean_covariance,
        arrival_rate=run.arrival_rate,
        stationary_arrival_rate=JointChannel.from_packets(sim.packets).stationary_arrival_rates(),
        packet_names=tuple(pk.name if pk.per_sensor and pk.name is not None else "" for pk in sim.packets),
        exact=exact,
        stationary=stationary,
        filtered_stats=run.filtered_stats,
        final_mean_filtered_covariance=run.final_mean_filtered_covariance,
        outage_target=None if target_spec is None else outage_target(sim, opts, target_spec, run_monte_carlo, budget),
    )


def _exact_analysis(request: Request) -> Any | None:
    """Theorem 1's report for the same request (tail exponent, growth rate), or ``None`` if it cannot be had."""
    from ..errors import AnalyzerError
    from ..stability import analyze

    try:
        return analyze(
            dataclasses.replace(request, options={}),
            Budget(seconds=min(EXACT_ANALYSIS_S, request.time_budget_s or EXACT_ANALYSIS_S)),
        )
    except (AnalyzerError, ArithmeticError):  # e.g. an OverflowError of the tail exponent at a 1e160 modulus
        return None
