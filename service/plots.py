"""PNG figures of analyzer results (matplotlib, Agg; run inside worker processes).

Figures are built with the object API (:class:`matplotlib.figure.Figure`),
never ``pyplot``: no global state, no GUI backend.  Each function takes a
validated request, a :class:`analyzer.Budget` and the plot's query
parameters, and returns PNG bytes.  They draw what the analyzer computes and
compute nothing of their own beyond the closed-form lower bound
``1 - 1/rho(A)^2`` (seed 004, Theorem 3) used to place the axis.
"""

from __future__ import annotations

import io
import math
from typing import Any, Mapping

import numpy as np

from analyzer import Budget, InvalidInput, Request
from analyzer.model import MarkovChannel, PerSensorChannel, to_float

from .jobs import call_with_budget, resolve

_SIZE = (7.0, 4.5)
_DPI = 100


def _figure() -> Any:
    from matplotlib.figure import Figure

    return Figure(figsize=_SIZE, dpi=_DPI, layout="constrained")


def _png(fig: Any) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})
    return buf.getvalue()


def _nan(values: Any) -> np.ndarray:
    return np.array([math.nan if v is None else float(v) for v in values], dtype=float)


def _bernoulli_lambda(request: Request, what: str) -> float:
    ch = request.channel
    if not isinstance(ch, MarkovChannel) or ch.model != "bernoulli":
        raise InvalidInput("/channel/model", f"the {what} plot is for one packet over a Bernoulli channel")
    return float(ch.table[0])


def _require_noise(request: Request, what: str) -> None:
    for name in ("Q", "R"):
        if getattr(request.system, name) is None:
            raise InvalidInput(f"/system/{name}", f"{name} is required for the {what} plot")


# -- simulated error bands ---------------------------------------------------


def simulation(request: Request, budget: Budget, params: Mapping[str, Any]) -> bytes:
    """``trace(P_t)`` against ``t``: mean with its 95% band, and the 50/90/99th percentiles.

    Draws :func:`analyzer.simulate.simulate`'s report, and the exact
    ``E[P_t]`` when ``options.simulate.exact_steps`` asked for it.
    """
    report = call_with_budget(resolve("analyzer.simulate", "simulate"), request, budget).to_dict()
    t = np.arange(report["steps"] + 1)
    fig = _figure()
    ax = fig.subplots()
    mean = _nan(report["mean_trace"])
    ax.fill_between(t, _nan(report["ci95_low"]), _nan(report["ci95_high"]), alpha=0.3, label="95% band of the mean")
    ax.plot(t, mean, lw=1.5, label="mean")
    for q, style in zip(("50", "90", "99"), (":", "--", "-.")):
        if q in report["percentiles"]:
            ax.plot(t, _nan(report["percentiles"][q]), style, lw=1, label=f"{q}th percentile")
    exact = report.get("exact")
    if exact:
        te = np.arange(len(exact["mean_trace"]))
        ax.plot(te, _nan(exact["mean_trace"]), "k.", ms=4, label="exact E[P_t]")
    if report.get("mean_diverged_at") is not None:
        ax.axvline(report["mean_diverged_at"], color="red", lw=1, label="first divergence")
    finite = mean[np.isfinite(mean)]
    if finite.size and finite.min() > 0 and finite.max() / finite.min() > 50:
        ax.set_yscale("log")
    ax.set_xlabel("t")
    ax.set_ylabel("trace(P_t)")
    ax.set_title(f"Simulated error covariance: {report['trajectories']} trajectories, seed {report['seed']}")
    ax.legend(fontsize="small")
    ax.grid(alpha=0.3)
    return _png(fig)


# -- phase transition (seed 004, Figs. 1-3) -----------------------------------


def _critical_values(request: Request, budget: Budget) -> dict[str, float | None]:
    """Lower and upper bounds on lambda_c from the bounds report (``None`` when absent)."""
    report = call_with_budget(resolve("analyzer.bounds", "compute_bounds"), request, budget).to_dict()
    crit = report.get("critical_probability") or {}
    return {k: (None if crit.get(k) is None else float(crit[k])) for k in ("lower", "upper")}


def phase_transition(request: Request, budget: Budget, params: Mapping[str, Any]) -> bytes:
    """``trace(S_bar)`` and ``trace(V_bar)`` against lambda, critical values marked.

    ``S_bar`` (exists for lambda above the lower bound) bounds the limit of
    ``E[P_t]`` from below, ``V_bar`` (exists above the LMI bound) from above
    (seed 004, Theorems 3-6).
    """
    lam0 = _bernoulli_lambda(request, "phase transition")
    _require_noise(request, "phase transition")
    s_bar = resolve("analyzer.riccati", "s_bar")
    v_bar = resolve("analyzer.riccati", "v_bar")
    crit = _critical_values(request, budget)
    A, C, Q, R = (to_float(getattr(request.system, k)) for k in ("A", "C", "Q", "R"))
    rho = float(max(abs(np.linalg.eigvals(A))))
    lower = crit["lower"] if crit["lower"] is not None else max(0.0, 1 - 1 / rho**2) if rho > 0 else 0.0
    lo = params.get("lambda_min")
    hi = params.get("lambda_max")
    lo = float(lo) if lo is not None else max(0.0, lower - 0.05)
    hi = float(hi) if hi is not None else 1.0
    lams = np.linspace(lo, hi, int(params.get("points", 100)))
    s_tr = np.full(lams.shape, math.nan)
    v_tr = np.full(lams.shape, math.nan)
    for i, lam in enumerate(lams):
        budget.tick("phase transition plot", 1)
        s_tr[i] = _trace_or_nan(s_bar, A, Q, 1.0 - lam)
        v_tr[i] = _trace_or_nan(v_bar, A, C, Q, R, lam)
    fig = _figure()
    ax = fig.subplots()
    ax.semilogy(lams, s_tr, label="trace(S_bar): lower bound")
    ax.semilogy(lams, v_tr, label="trace(V_bar): upper bound")
    for value, name, style in ((crit["lower"] if crit["lower"] is not None else lower, "lambda lower", ":"),
                               (crit["upper"], "lambda upper (LMI)", "--")):
        if value is not None and lo <= value <= hi:
            ax.axvline(value, color="gray", ls=style, lw=1, label=f"{name} = {value:.4g}")
    if lo <= lam0 <= hi:
        ax.axvline(lam0, color="black", lw=0.8, alpha=0.6, label=f"request: lambda = {lam0:.4g}")
    ax.set_xlim(lo, hi)
    ax.set_xlabel("arrival probability lambda")
    ax.set_ylabel("trace")
    ax.set_title("Phase transition of the expected error covariance")
    ax.legend(fontsize="small")
    ax.grid(alpha=0.3, which="both")
    return _png(fig)


def _trace_or_nan(fn: Any, *args: Any) -> float:
    """``trace(fn(*args))``; NaN where the bound does not exist (``None``, non-finite, or refused)."""
    from analyzer import AnalyzerError

    try:
        value = fn(*args)
    except (AnalyzerError, ArithmeticError, np.linalg.LinAlgError):
        return math.nan
    if value is None:
        return math.nan
    tr = float(np.trace(np.asarray(value, dtype=float)))
    return tr if math.isfinite(tr) and tr >= 0 else math.nan


# -- region map for two sensors (seed 000, Figs. 4-5) -------------------------


def _two_bernoulli_sensors(request: Request) -> tuple[str, str]:
    ch = request.channel
    if not isinstance(ch, PerSensorChannel) or len(ch.channels) != 2:
        raise InvalidInput("/channel/model", "the region plot needs two sensors with a per_sensor channel")
    for name, c in ch.channels:
        if c.model != "bernoulli":
            raise InvalidInput(f"/channel/channels/{name}/model", "the region plot needs Bernoulli channels")
    return ch.channels[0][0], ch.channels[1][0]


def region(request: Request, budget: Budget, params: Mapping[str, Any]) -> bytes:
    """The ``(lambda_1, lambda_2)`` square for two sensors: stable, unstable, undecided.

    Unstable by the lower bound ``(1 - lambda_1)(1 - lambda_2) rho(A)^2 >= 1``
    and stable by the LMI (seed 000, Theorems 3-4) as the bounds report says
    at each grid point; kfio's exact verdict (MATH.md, "exact partial-loss
    regions") is overlaid as markers where the analyzer gives one.
    """
    import dataclasses

    names = _two_bernoulli_sensors(request)
    points = int(params.get("points", 21))
    grid = np.linspace(0.0, 1.0, points + 2)[1:-1]  # Assumption 1: strictly inside (0, 1)
    bounds_fn = resolve("analyzer.bounds", "compute_bounds")
    try:
        analyze_fn = resolve("analyzer", "analyze")
    except Exception:  # noqa: BLE001 - the overlay is optional
        analyze_fn = None
    bound_map = np.zeros((points, points))  # -1 unstable, +1 stable, 0 undecided
    exact_map = np.full((points, points), math.nan)
    for i, l1 in enumerate(grid):
        for j, l2 in enumerate(grid):
            budget.tick("region plot", 1)
            chans = tuple(
                (n, MarkovChannel("bernoulli", 0, (_frac(lam),), {"arrival_probability": _frac(lam)}))
                for n, lam in zip(names, (l1, l2))
            )
            point = dataclasses.replace(request, channel=PerSensorChannel(chans))
            bound_map[j, i] = _bounds_verdict(call_with_budget(bounds_fn, point, budget).to_dict())
            if analyze_fn is not None:
                exact_map[j, i] = _exact_verdict(analyze_fn, point, budget)
    return _draw_region(grid, bound_map, exact_map, names, request)


def _frac(x: float) -> Any:
    from fractions import Fraction

    return Fraction(x).limit_denominator(10**6)


def _bounds_verdict(report: Mapping[str, Any]) -> float:
    verdict = report.get("region_verdict") or report.get("verdict")
    return {"unstable": -1.0, "stable": 1.0}.get(str(verdict), 0.0)


def _exact_verdict(analyze_fn: Any, point: Request, budget: Budget) -> float:
    from analyzer import AnalyzerError

    try:
        verdict = call_with_budget(analyze_fn, point, budget).verdict
    except (AnalyzerError, NotImplementedError):
        return math.nan
    return {"unstable": -1.0, "stable": 1.0, "boundary": 0.0}.get(verdict, math.nan)


def _draw_region(grid: np.ndarray, bound_map: np.ndarray, exact_map: np.ndarray, names: tuple[str, str], request: Request) -> bytes:
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    fig = _figure()
    ax = fig.subplots()
    step = grid[1] - grid[0] if len(grid) > 1 else 1.0
    extent = (grid[0] - step / 2, grid[-1] + step / 2, grid[0] - step / 2, grid[-1] + step / 2)
    cmap = ListedColormap(["#e8a0a0", "#f0f0c0", "#a0d0a0"])
    ax.imshow(bound_map, origin="lower", extent=extent, cmap=cmap, vmin=-1, vmax=1, interpolation="nearest", aspect="auto")
    xs, ys = np.meshgrid(grid, grid)
    handles = [
        Patch(color="#a0d0a0", label="stable (LMI bound)"),
        Patch(color="#f0f0c0", label="undecided by the bounds"),
        Patch(color="#e8a0a0", label="unstable (lower bound)"),
    ]
    for value, marker, label in ((1.0, "o", "exact: stable"), (-1.0, "x", "exact: unstable"), (0.0, "s", "exact: boundary")):
        mask = exact_map == value
        if mask.any():
            handles.append(ax.scatter(xs[mask], ys[mask], marker=marker, s=10, c="k", lw=0.8, label=label))
    chans = dict(request.channel.channels)  # type: ignore[union-attr]
    p = (float(chans[names[0]].table[0]), float(chans[names[1]].table[0]))
    handles.append(ax.scatter([p[0]], [p[1]], marker="*", s=120, c="blue", label="request"))
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    ax.set_xlabel(f"lambda_1 (sensor {names[0]!r})")
    ax.set_ylabel(f"lambda_2 (sensor {names[1]!r})")
    ax.set_title("Stability region for two sensors")
    ax.legend(handles=handles, fontsize="x-small", loc="lower left")
    return _png(fig)
