"""The classical bounds of docs/theory.md, for one request.

For Bernoulli packet losses (one packet: Sinopoli et al. (2004) and Rohr, Marelli and Fu (2010); several
independent packets: Liu and Goldsmith (2004), generalized to ``m`` packets):

* the critical arrival probability: the closed-form lower bound and the
  LMI upper bound (bisection, re-checked certificates), per sensor when
  there are several;
* at the operating point: ``S_bar <= lim E[P_t] <= V_bar`` (Lyapunov; MARE
  fixed point by iteration and by SDP, cross-checked), a stable / unstable /
  undecided verdict by the bounds;
* one packet: Rohr, Marelli and Fu (2010)'s ``P_hat_N`` and the variance threshold;
* two packets with ``grid``: the region map of Liu and Goldsmith (2004), Figs. 4-5.

Public entry: :func:`compute_bounds`.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any, Mapping

import numpy as np

from .._budget import Budget
from .._verdicts import Verdict
from ..errors import InvalidInput
from ..model import Request, to_float
from ._certificate import ExactPlant, StabilityCertificate
from ._filtered import filtered_bounds, filtered_mean
from ._options import BoundsOptions, parse_bounds_options
from ._phat import PHat, p_hat_sequence
from ._report import BoundsReport, CovarianceBounds, CriticalInterval, PHatBounds, RegionMap
from ._riccati import ArrivalModel, arrival_model, lyapunov_residual, s_bar, solve_v_bar, spectral_radius, subset_rows
from ._search import CertifiedSearch
from ._targets import parse_trace_target, smallest_arrival_for_trace
from ._vbar_sdp import SDPSolution, v_bar_sdp

__all__ = ["BoundsReport", "compute_bounds", "critical_lower_bound", "hypotheses"]

#: Relative singular-value threshold of the PBH rank tests.
RANK_TOL = 1e-9


def critical_lower_bound(rho: float, others_loss: float = 1.0) -> float:
    """``max(0, 1 - 1/(rho^2 * others_loss))``: Sinopoli et al. (2004) Theorem 3, Liu and Goldsmith (2004) Theorem 3.

    ``others_loss = prod_{r != s} (1 - lambda_r)`` for the other packets.

    Examples
    --------
    >>> round(critical_lower_bound(1.25), 12)
    0.36
    >>> critical_lower_bound(0.9)
    0.0
    """
    d = rho * rho * others_loss
    return max(0.0, 1.0 - 1.0 / d) if d > 0 else 0.0


def _full_rank(M: np.ndarray) -> bool:
    s = np.linalg.svd(M, compute_uv=False)
    return bool(s[-1] > RANK_TOL * max(1.0, s[0]))


def hypotheses(A: np.ndarray, C: np.ndarray, Q: np.ndarray) -> dict[str, Any]:
    """The hypotheses of Sinopoli et al. (2004) Theorems 2-5, by PBH rank tests in floating point.

    ``(A, C)`` detectable: ``[A - theta I; C]`` has full column rank for every
    eigenvalue ``|theta| >= 1``; ``(A, Q^1/2)`` controllable: ``[A - theta I,
    Q^1/2]`` has full row rank for every eigenvalue.
    """
    n = A.shape[0]
    eig = np.linalg.eigvals(A)
    w, U = np.linalg.eigh(Q)
    Qh = U * np.sqrt(np.clip(w, 0.0, None))
    detectable = all(_full_rank(np.vstack([A - t * np.eye(n), C])) for t in eig if abs(t) >= 1)
    controllable = all(_full_rank(np.hstack([A - t * np.eye(n), Qh])) for t in eig)
    return {
        "A_unstable": bool(spectral_radius(A) >= 1),
        "A_C_detectable": detectable,
        "A_Q_controllable": controllable,
        "method": f"PBH rank tests in floating point (relative singular-value threshold {RANK_TOL:g})",
    }


def _interval(search: CertifiedSearch, s: int, opts: BoundsOptions, rho: float) -> CriticalInterval:
    lams = opts.arrival
    others = float(np.prod([1.0 - float(x) for r, x in enumerate(lams) if r != s]))
    lower = critical_lower_bound(rho, others)
    upper = search.bisect(lams, s, lower, opts.tolerance)
    return CriticalInterval(opts.packets[s], lams[s], lower, upper, opts.tolerance)


def _verdict(
    search: CertifiedSearch, model: ArrivalModel, rho: float, lams: tuple[Fraction, ...]
) -> tuple[Verdict, str, StabilityCertificate | None]:
    if model.loss_probability * rho * rho >= 1.0:
        return (
            Verdict.UNSTABLE,
            "prod (1 - lambda) rho(A)^2 >= 1: the lower bound S_bar diverges (Sinopoli et al. 2004, Theorem 3)",
            None,
        )
    cert = search.certify(lams)
    if cert is not None:
        return (
            Verdict.STABLE,
            "the stability LMI is feasible here, certificate re-checked (Sinopoli et al. 2004, Theorems 3 and 5)",
            cert,
        )
    return (
        Verdict.UNDECIDED,
        "between the bounds: the lower bound does not diverge and no LMI certificate was found",
        None,
    )


def _covariance(model: ArrivalModel, budget: Budget, opts: BoundsOptions) -> CovarianceBounds:
    """``S_bar`` and ``V_bar``; the SDP of Sinopoli et al. (2004) Theorem 6(b) cross-checks ``V_bar`` per ``opts``.

    ``V_bar`` itself always comes from the MARE iteration (:func:`solve_v_bar`); the SDP only
    confirms it, so skipping it (above 12 states by default) changes no bound.
    """
    p0 = model.loss_probability
    S = s_bar(model.A, model.Q, p0)
    res = None if S is None else lyapunov_residual(S, model.A, model.Q, p0)
    it = solve_v_bar(model, budget=budget)
    filtered = filtered_bounds(model, S, it.matrix)
    if it.matrix is None:
        return CovarianceBounds(
            S, res, it, None, "not solved: V_bar does not exist, the SDP would be unbounded", filtered
        )
    why = opts.sdp_skipped_because(model.n)
    if why is not None:
        return CovarianceBounds(S, res, it, SDPSolution("skipped", None, None), why, filtered)
    return CovarianceBounds(S, res, it, v_bar_sdp(model), None, filtered)


def _p_hat(
    A: np.ndarray, C: np.ndarray, Q: np.ndarray, R: np.ndarray, lam: float, horizon: int, budget: Budget
) -> PHatBounds:
    """Rohr, Marelli and Fu (2010)'s ``P_hat_N`` for ``N = 1, 2, 4, ...`` and ``horizon``.

    ``P_hat_1 = V_bar``: :func:`solve_v_bar` remembers the covariance part's answer for the same
    floats, so the MARE is solved once per request.
    """
    wanted = sorted({1 << k for k in range(horizon.bit_length()) if 1 << k <= horizon} | {horizon})
    if (1.0 - lam) * spectral_radius(A) ** 2 >= 1.0:
        # P_hat_N >= lim E[P_t] >= S_bar = infinity (Rohr, Marelli and Fu (2010) Theorem 1, Sinopoli et al. (2004) Theorem 3): no need to iterate.
        why = "(1 - lambda) rho(A)^2 >= 1: E[P_t] diverges, and P_hat_N >= lim E[P_t]"
        return PHatBounds(horizon, tuple(PHat(N, None, 0, None, 0, why) for N in wanted))
    seq = p_hat_sequence(A, C, Q, R, lam, wanted, budget=budget)
    model = ArrivalModel(A, Q, (C,), (R,), (1.0 - lam, lam))
    entries = tuple(seq[N] for N in wanted)
    filtered = tuple(None if e.matrix is None else filtered_mean(model, e.matrix) for e in entries)
    return PHatBounds(horizon, entries, filtered)


def _region(search: CertifiedSearch, opts: BoundsOptions, rho: float, request: Request, budget: Budget) -> RegionMap:
    """The bounds' map of the square (Liu and Goldsmith (2004), Figs. 4-5) with kfio's exact labels and boundary beside it.

    The exact part is :func:`kfio.design._regions.exact_region_grid` (an extension
    of Rohr, Marelli and Fu (2014), docs/theory.md); it is absent when the request's channels
    are outside Assumption 1 of Rohr, Marelli and Fu (2014).
    """
    from ..errors import AssumptionViolation
    from ..stability import exact_region_grid

    K = opts.grid
    assert K is not None
    values = tuple(Fraction(i, K - 1) for i in range(K))
    unstable = np.array([[float((1 - a) * (1 - b)) * rho * rho >= 1.0 for b in values] for a in values])
    before = search.solves
    labels, certified = search.region(values, unstable)
    names = tuple(p.name or f"sensor {i}" for i, p in enumerate(opts.packets))
    try:
        exact = exact_region_grid(request, K, budget=budget)
    except AssumptionViolation:
        exact = None
    return RegionMap(
        (names[0], names[1]), values, tuple(tuple(r) for r in labels), certified, search.solves - before, exact
    )


def compute_bounds(
    request: Request, budget: Budget | None = None, *, flags: Mapping[str, Any] | None = None
) -> BoundsReport:
    """All bounds of docs/theory.md for ``request``.

    Parameters
    ----------
    request:
        A validated request; ``options["bounds"]`` may set ``tolerance``,
        ``horizon``, ``grid`` and ``arrival_probability``.
    budget:
        Work budget; by default ``request.time_budget_s`` seconds.
    flags:
        Command-line overrides of the options (``tolerance``, ``horizon``, ``grid``).

    Raises
    ------
    InvalidInput
        Missing ``Q``/``R``, a channel with memory, a bad option (the field
        is named).
    BudgetExceeded
        The work did not fit the budget.

    Examples
    --------
    >>> from kfio import load_request
    >>> req = load_request('{"system": {"A": [[-1.25]], "C": [[1]], "Q": [[1]], "R": [[2.5]]},'
    ...                    ' "channel": {"model": "bernoulli", "arrival_probability": 0.4}}')
    >>> rep = compute_bounds(req)
    >>> round(rep.critical[0].lower, 9), abs(float(rep.critical[0].upper.value) - 0.36) < 1e-6
    (0.36, True)
    """
    opts = parse_bounds_options(request, flags)
    budget = budget if budget is not None else Budget(seconds=request.time_budget_s)
    system = request.system
    assert system.Q is not None and system.R is not None  # checked by parse_bounds_options
    A, C, Q, R = (to_float(M) for M in (system.A, system.C, system.Q, system.R))
    groups = [list(p.rows) for p in opts.packets]
    lams = opts.arrival
    model = arrival_model(A, C, Q, R, groups, [float(x) for x in lams])
    rho = spectral_radius(A)
    plant = ExactPlant(system.A, tuple(tuple(system.C[r] for r in rows) for rows in subset_rows(groups)))
    search = CertifiedSearch(A, C, groups, plant, budget)

    critical = tuple(_interval(search, s, opts, rho) for s in range(len(opts.packets)))
    verdict, reason, cert = _verdict(search, model, rho, lams)
    covariance = _covariance(model, budget, opts)
    one = len(opts.packets) == 1
    p_hat = None
    if one and opts.horizon is not None:
        rows = list(opts.packets[0].rows)
        p_hat = _p_hat(A, C[rows, :], Q, R[np.ix_(rows, rows)], float(lams[0]), opts.horizon, budget)
    region = _region(search, opts, rho, request, budget) if opts.grid is not None else None
    target = parse_trace_target(request)
    if target is not None and not one:
        raise InvalidInput("/options/bounds/trace_target", "trace_target needs one packet")
    if target is not None:
        rows = list(opts.packets[0].rows)
        target_report = smallest_arrival_for_trace(A, C[rows, :], Q, R[np.ix_(rows, rows)], target, budget=budget)
    return BoundsReport(
        packets=opts.packets,
        arrival=lams,
        rho=rho,
        hypotheses=hypotheses(A, C, Q),
        verdict=verdict,
        verdict_reason=reason,
        verdict_certificate=cert,
        critical=critical,
        variance_threshold=critical_lower_bound(rho * rho) if one else None,
        covariance=covariance,
        p_hat=p_hat,
        region=region,
        trace_target=target_report if target is not None else None,
    )
