"""PNG figures of analyzer results (matplotlib, Agg; run inside worker processes).

Figures are built with the object API (:class:`matplotlib.figure.Figure`),
never ``pyplot``: no global state, no GUI backend.  Each function takes a
validated request, a :class:`kfio.Budget` and the plot's query
parameters, and returns PNG bytes.  They compute nothing of their own:
every value drawn comes from :mod:`kfio` (the same calls as the CLI).
"""

from __future__ import annotations

import io
import math
from typing import Any, Mapping

import numpy as np

from kfio import Budget, InvalidInput, Request
from kfio.errors import AnalyzerError, NumericalFailure
from kfio.model import MarkovChannel, PerSensorChannel, to_float

_SIZE = (7.0, 4.5)
_DPI = 100


def new_figure() -> Any:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=_SIZE, dpi=_DPI, layout="constrained")
    FigureCanvasAgg(fig)  # a renderer to measure text with (titles are fitted to the width)
    return fig


def png_bytes(fig: Any) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})
    return buf.getvalue()


#: The smallest text of a figure, in points at :data:`_DPI`: the page shows a plot at no less than
#: about 3/4 of its pixels (narrower screens scroll it), so this stays about 8 CSS pixels or more.
MIN_FONT_PT = 8.5
#: Legend text, in points.
LEGEND_FONT_PT = 9.0


def figure_headline(fig: Any, text: str, fontsize: float = 10.5) -> Any:
    """The figure's title (the exact verdict first): every line fits the figure's width.

    A figure title, not an axes title: it is centred on the figure.  A line too
    wide is first set smaller, down to :data:`MIN_FONT_PT`, then wrapped at
    word boundaries, so no text becomes too small to read.
    """
    import textwrap

    title = fig.suptitle(text, fontsize=fontsize, parse_math=False)
    renderer = fig.canvas.get_renderer()
    limit = 0.98 * fig.bbox.width
    while title.get_window_extent(renderer).width > limit and title.get_fontsize() > MIN_FONT_PT:
        title.set_fontsize(max(MIN_FONT_PT, title.get_fontsize() - 0.5))
    width = title.get_window_extent(renderer).width
    if width > limit:
        longest = max(len(line) for line in text.splitlines())
        chars = max(20, int(longest * limit / width))
        title.set_text("\n".join(textwrap.fill(line, chars) for line in text.splitlines()))
    return title


def legend_outside(ax: Any, handles: Any = None, fontsize: float = LEGEND_FONT_PT) -> Any:
    """The legend above the axes (outside them, under the title), in columns: it never covers data.

    Above rather than beside: beside the axes it took a third of the width, and a
    page on a phone then showed the plot and its legend at a few pixels a letter.
    """
    kwargs: dict[str, Any] = {} if handles is None else {"handles": handles}
    n = len(handles) if handles is not None else len(ax.get_legend_handles_labels()[0])
    return ax.legend(
        fontsize=max(MIN_FONT_PT, fontsize),
        loc="lower center",
        bbox_to_anchor=(0.5, 1.02),
        borderaxespad=0.0,
        ncols=2 if n > 2 else max(1, n),
        frameon=False,
        **kwargs,
    )


#: The name the loop and sweep plots import.
legend_beside = legend_outside


_SUPERSCRIPT = str.maketrans("0123456789-", "\u2070\u00b9\u00b2\u00b3\u2074\u2075\u2076\u2077\u2078\u2079\u207b")


def pretty_powers(text: str) -> str:
    """``(1 - p)**2*q`` as ``(1 - p)\u00b2\u00b7q``: powers as superscripts, products as a dot (a plot's label).

    Examples
    --------
    >>> pretty_powers("(1 - p)**2*q**(-1) = 1")
    '(1 - p)\u00b2\u00b7q\u207b\u00b9 = 1'
    """
    import re

    text = re.sub(r"\*\*\((-?\d+)\)|\*\*(\d+)", lambda m: (m.group(1) or m.group(2)).translate(_SUPERSCRIPT), text)
    return re.sub(r"\s*\*\s*", "\u00b7", text)


def _verdict_text(verdict: str | None) -> str:
    """The exact verdict as a headline (Rohr, Marelli and Fu 2014, Theorem 1), or that none was computed."""
    if verdict is None:
        return "exact verdict not computed"
    return f"{verdict.upper()} (exact, Rohr, Marelli and Fu 2014, Thm 1)"


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
    """``trace(P_t)`` against ``t``: percentiles, the mean with its 95% band, exact ``E[P_t]`` if asked.

    Draws :func:`kfio.simulation._simulate.simulate`'s report: the predictor
    ``P_t = P(t|t-1)``, and beside it the mean and median of the filtered
    ``P(t|t)`` of the same arrivals (the report's ``filtered`` section).  Where the
    exact tail exponent is ``kappa <= 2`` (Mo and Sinopoli, 2012) the mean is
    unreliable: the percentiles come first, the mean is drawn thin, and the
    exact per-step growth of ``E[P_t]`` (Theorem 1's rate) is drawn as a slope
    beside it.  On a log axis the band is drawn only where its lower end is
    positive; elsewhere only its upper edge (a log axis cannot show 0).
    """
    from kfio.simulation import simulate

    return png_bytes(simulation_figure(simulate(request, budget=budget).to_dict(), request))


def simulation_figure(report: Mapping[str, Any], request: Request) -> Any:
    """The figure of :func:`simulation` for a simulation report (its ``to_dict()``).

    The title starts with the exact verdict the report carries
    (``stationary.verdict``, Theorem 1), then what the sample shows
    (:func:`kfio.simulation._stationary.verdict_headline`).
    """
    from kfio.simulation import verdict_headline

    t = np.arange(report["steps"] + 1)
    stationary = report.get("stationary") or {}
    unreliable = bool(stationary.get("mean_unreliable"))
    fig = new_figure()
    ax = fig.subplots()
    mean = _nan(report["mean_trace"])
    low, high = _nan(report["ci95_low"]), _nan(report["ci95_high"])
    for q, style in zip(("50", "90", "99"), ("-", "--", "-.")):
        if q in report["percentiles"]:
            ax.plot(t, _nan(report["percentiles"][q]), style, lw=1.6 if unreliable else 1, label=f"{q}th percentile")
    finite = np.concatenate([mean[np.isfinite(mean)], _nan(report["percentiles"].get("99", []))])
    finite = finite[np.isfinite(finite) & (finite > 0)]
    log_axis = bool(finite.size and finite.max() / finite.min() > 50)
    band_ok = low > 0 if log_axis else np.isfinite(low)
    ax.fill_between(t, low, high, where=band_ok, alpha=0.25, color="C0", label="95% band of the mean")
    if log_axis and (~band_ok & np.isfinite(high)).any():
        ax.plot(t, np.where(band_ok, np.nan, high), ":", color="C0", lw=1, label="band upper edge (lower end <= 0)")
    ax.plot(t, mean, lw=0.8 if unreliable else 1.5, color="grey" if unreliable else "C0", label="sample mean")
    filtered = report.get("filtered")
    if filtered:
        ax.plot(t, _nan(filtered["mean_trace"]), lw=1, color="C4", label="filtered P(t|t): sample mean")
        if "50" in filtered["percentiles"]:
            ax.plot(t, _nan(filtered["percentiles"]["50"]), ":", lw=1, color="C4", label="filtered P(t|t): median")
    growth = stationary.get("exact_mean_growth_per_step")
    if unreliable and growth is not None and growth > 1:
        t0 = max(1, len(t) // 4)
        if math.isfinite(mean[t0]) and mean[t0] > 0:
            slope = mean[t0] * growth ** (t[t0:] - t0)
            ax.plot(t[t0:], slope, color="red", lw=1, label=f"exact growth of E[P_t]: x{growth:.4g} per step")
    exact = report.get("exact")
    if exact:
        te = np.arange(len(exact["mean_trace"]))
        ax.plot(te, _nan(exact["mean_trace"]), "k.", ms=4, label="exact E[P_t]")
    if report.get("mean_diverged_at") is not None:
        ax.axvline(report["mean_diverged_at"], color="red", lw=1, label="first divergence")
    if log_axis:
        ax.set_yscale("log")
        top = np.nanmax(np.where(np.isfinite(finite), finite, np.nan)) if finite.size else None
        if top is not None:
            ax.set_ylim(top=top * 10)
    ax.set_xlabel("t")
    ax.set_ylabel("trace(P_t), P_t = P(t|t-1)")
    exact, sample = verdict_headline(
        stationary.get("verdict"),
        stationary.get("tail_exponent_exact"),
        report.get("mean_diverged_at"),
        report["steps"],
    )
    if stationary.get("verdict") is None:
        exact = _verdict_text(None)
    figure_headline(
        fig,
        f"{exact}: n = {request.system.n}, {_channel_text(request)}\n"
        f"{sample}; {report['trajectories']} trajectories, seed {report['seed']}",
    )
    legend_outside(ax)
    ax.grid(alpha=0.3)
    return fig


def _channel_text(request: Request) -> str:
    ch = request.channel
    if isinstance(ch, PerSensorChannel):
        return f"{len(ch.channels)} sensors"
    d = ch.describe()
    params = ", ".join(f"{k} {v}" for k, v in d.items() if k not in ("model", "order"))
    return f"{ch.model} ({params})" if ch.model != "markov" else f"Markov order {ch.order}"


# -- phase transition (Sinopoli et al. 2004, Figs. 1-3) ------------------------


def _value(node: Any) -> float | None:
    return None if node is None or node.get("value") is None else float(node["value"])


def _critical_values(request: Request, budget: Budget) -> dict[str, Any]:
    """Bounds on lambda_c (:func:`kfio.riccati_bounds._compute.compute_bounds`) and the exact value (:func:`kfio.analyze`)."""
    from kfio import analyze
    from kfio.riccati_bounds import compute_bounds

    report = compute_bounds(request, budget=budget).to_dict()
    crit = report.get("critical_probability") or {}
    exact = analyze(request, budget=budget).to_dict()
    value = exact.get("critical_arrival_probability")
    return {
        "lower": _value(crit.get("lower")),
        "upper": _value(crit.get("upper")),
        "exact": None if value is None else float(value),
        "verdict": exact.get("verdict"),
    }


def phase_transition(request: Request, budget: Budget, params: Mapping[str, Any]) -> bytes:
    """``trace(S_bar)`` and ``trace(V_bar)`` against lambda, critical values marked.

    The traces come from :func:`kfio.riccati_bounds._sweep.bound_traces`: ``S_bar``
    (exists for lambda above the lower bound) bounds the limit of ``E[P_t]``
    from below and ``V_bar`` (exists above the LMI bound) from above
    (Sinopoli et al. 2004, Theorems 3-6).  Marked: the lower bound
    ``1 - 1/rho(A)^2``, the LMI upper bound and kfio's exact ``lambda_c``
    (Rohr, Marelli and Fu 2014).

    ``V_bar`` is evaluated only above the LMI bound: the MARE iteration
    converges exactly where the LMI is feasible (Sinopoli et al. 2004,
    Theorem 5), and just below that point its divergence is slow to detect
    (seconds per point).
    """
    lam0 = _bernoulli_lambda(request, "phase transition")
    _require_noise(request, "phase transition")
    from kfio.riccati_bounds import bound_traces

    crit = _critical_values(request, budget)
    A, C, Q, R = (to_float(getattr(request.system, k)) for k in ("A", "C", "Q", "R"))
    lower = crit["lower"] or 0.0
    lo = params.get("lambda_min")
    hi = params.get("lambda_max")
    lo = float(lo) if lo is not None else max(0.0, lower - 0.05)
    hi = float(hi) if hi is not None else 1.0
    traces = bound_traces(
        A, C, Q, R, np.linspace(lo, hi, int(params.get("points", 100))), v_bar_from=crit["upper"], budget=budget
    )
    lams, s_tr, v_tr = traces.lambdas, traces.s_bar, traces.v_bar
    fig = new_figure()
    ax = fig.subplots()
    ax.plot(lams, s_tr, label="trace(S_bar): lower bound on lim E[P_t]")
    ax.plot(lams, v_tr, label="trace(V_bar): upper bound on lim E[P_t]")
    if np.isfinite(np.concatenate([s_tr, v_tr])).any():
        ax.set_yscale("log")
    marks = (
        (crit["lower"], "lambda lower bound", ":", "tab:blue"),
        (crit["upper"], "lambda upper bound (LMI)", "--", "tab:orange"),
        (crit["exact"], "lambda_c exact (kfio)", "-", "black"),
        (lam0, "request: lambda", "-.", "tab:green"),
    )
    for value, name, style, color in marks:
        if value is not None and lo <= value <= hi:
            ax.axvline(value, color=color, ls=style, lw=1, label=f"{name} = {value:.4g}")
    ax.set_xlim(lo, hi)
    ax.set_xlabel("arrival probability lambda")
    ax.set_ylabel("trace")
    figure_headline(
        fig,
        f"{_verdict_text(crit['verdict'])} at lambda = {lam0:.4g}\n"
        "Phase transition of lim E[P_t]: bounds (Sinopoli et al. 2004) and exact lambda_c",
    )
    legend_outside(ax)
    ax.grid(alpha=0.3, which="both")
    return png_bytes(fig)


# -- region map for two sensors (Liu and Goldsmith 2004, Figs. 4-5) ------------

_LABEL_CODE = {"unstable": -1.0, "undecided": 0.0, "stable": 1.0}


def region(request: Request, budget: Budget, params: Mapping[str, Any]) -> bytes:
    """The ``(lambda_1, lambda_2)`` square for two sensors: stable, unstable, undecided.

    Everything drawn is the bounds report's (``options.bounds.grid`` set to
    the ``points`` parameter): the coloured map, unstable by the lower bound
    and stable by the LMI of Liu and Goldsmith (2004), and over it the exact
    labels of every cell and the exact boundary curve ``lambda_2 = h(lambda_1)``
    that the report carries (:func:`kfio.design._regions.exact_region_grid`,
    a kfio extension of Rohr, Marelli and Fu 2014).
    """
    import dataclasses

    from kfio import analyze
    from kfio.riccati_bounds import compute_bounds
    from kfio.stability import exact_region_grid

    if not isinstance(request.channel, PerSensorChannel) or len(request.channel.channels) != 2:
        raise InvalidInput("/channel/model", "the region plot needs two sensors with a per_sensor channel")
    points = int(params.get("points", 21))
    grid_options = {**request.options.get("bounds", {}), "grid": points}
    gridded = dataclasses.replace(request, options={**request.options, "bounds": grid_options})
    bounds = compute_bounds(gridded, budget=budget)
    if bounds.region is None:  # options.bounds.grid with two sensors always adds it; say so if it ever does not
        raise NumericalFailure("/options/bounds/grid", "the bounds computation returned no region map")
    report = bounds.region.to_dict()
    values = np.array(report["values"], dtype=float)
    labels = np.array([[_LABEL_CODE.get(x, 0.0) for x in row] for row in report["labels"]])
    grid = bounds.region.exact
    if grid is None:  # outside Assumption 1: let the exact route say why
        grid = exact_region_grid(request, points, budget=budget)
    exact = np.array([[_EXACT_CODE[x] for x in row] for row in grid.labels])
    try:
        verdict: str | None = analyze(request, budget=budget).verdict
    except AnalyzerError:  # the title then says no exact verdict was computed; the map is still the bounds'
        verdict = None
    return png_bytes(region_figure(values, labels, exact, grid.curve, tuple(report["axes"]), request, verdict))


_EXACT_CODE = {"unstable": -1.0, "stable": 1.0, "boundary": 0.0}


def region_figure(
    values: np.ndarray,
    labels: np.ndarray,
    exact: np.ndarray,
    curve: Any,
    axes: tuple[str, ...],
    request: Request,
    verdict: str | None,
) -> Any:
    """The figure of :func:`region`: bound labels, exact labels and curve, the request marked, the verdict on top."""
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    fig = new_figure()
    ax = fig.subplots()
    step = values[1] - values[0] if len(values) > 1 else 1.0
    extent = (values[0] - step / 2, values[-1] + step / 2, values[0] - step / 2, values[-1] + step / 2)
    cmap = ListedColormap(["#e8a0a0", "#f0f0c0", "#a0d0a0"])
    # labels[i][j] is lambda_1 = values[i], lambda_2 = values[j]: lambda_1 on the x axis
    ax.imshow(
        labels.T, origin="lower", extent=extent, cmap=cmap, vmin=-1, vmax=1, interpolation="nearest", aspect="auto"
    )
    handles: list[Any] = [
        Patch(color="#a0d0a0", label="stable (LMI bound)"),
        Patch(color="#f0f0c0", label="undecided by the bounds"),
        Patch(color="#e8a0a0", label="unstable (lower bound)"),
    ]
    x1, x2 = np.meshgrid(values, values, indexing="ij")
    for code, marker, label in (
        (1.0, "o", "exact: stable"),
        (-1.0, "x", "exact: unstable"),
        (0.0, "s", "exact: boundary"),
    ):
        mask = exact == code
        if mask.any():
            handles.append(ax.scatter(x1[mask], x2[mask], marker=marker, s=14, c="k", lw=0.8, label=label))
    xs = [x for x, y in curve.samples if y is not None]
    ys = [y for _, y in curve.samples if y is not None]
    if xs:
        (line,) = ax.plot(xs, ys, color="navy", lw=1.6, label="exact boundary lambda_2 = h(lambda_1)")
        handles.append(line)
    lam1_min = curve.envelope.lambda_1_min
    if lam1_min is not None and curve.envelope.vertical:
        ax.axvline(lam1_min, color="navy", lw=1.6)
    chans = dict(request.channel.channels)  # type: ignore[union-attr]
    point = [float(chans[name].table[0]) for name, _ in request.channel.channels]  # type: ignore[union-attr]
    handles.append(ax.scatter([point[0]], [point[1]], marker="*", s=140, c="blue", label="request"))
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    # sensor names are user text: drawn as plain text, never through mathtext or TeX
    ax.set_xlabel(f"lambda_1 ({axes[0]})", parse_math=False, usetex=False)
    ax.set_ylabel(f"lambda_2 ({axes[1]})", parse_math=False, usetex=False)
    figure_headline(
        fig,
        f"{_verdict_text(verdict)} at the request (star), lambda = ({point[0]:.4g}, {point[1]:.4g})\n"
        "Two sensors: bounds (colours, Liu and Goldsmith 2004); exact (markers, line: kfio extension of "
        "Rohr, Marelli and Fu 2014)",
    )
    legend_outside(ax, handles)
    return fig


# -- exact Gilbert-Elliott region ----------------------------------------------


def ge_region(request: Request, budget: Budget, params: Mapping[str, Any]) -> bytes:
    """The (recovery rate q, failure rate p) square of a Gilbert-Elliott channel, labelled exactly.

    Every cell is Theorem 1's exact verdict (Rohr, Marelli and Fu, 2014) at its
    centre; the lines are the boundary ``|alpha_k|^2 sigma_k(p, q) = 1`` traced by
    :func:`kfio.design._ge_boundary.boundary_lines` (the same lines a (p, q)
    sweep's plot draws), one colour per closed-form piece; the star is the request.
    """
    import dataclasses

    from kfio.stability import analyze

    ch = request.channel
    if not isinstance(ch, MarkovChannel) or ch.model != "gilbert_elliott":
        raise InvalidInput("/channel/model", "the Gilbert-Elliott region plot needs one gilbert_elliott channel")
    points = int(params.get("points", 41))
    opts = {**request.options.get("analyze", {}), "ge_grid": points}
    gridded = dataclasses.replace(request, options={**request.options, "analyze": opts})
    report = analyze(gridded, budget)
    return draw_ge_region(report.gilbert_elliott, report.verdict, request)


def draw_ge_region(region: Any, verdict: str, request: Request) -> bytes:
    return png_bytes(ge_region_figure(region, verdict, request))


#: Gid of the boundary lines in the Gilbert-Elliott and sweep figures (tests find them by it).
GE_BOUNDARY_GID = "ge-boundary"


def ge_region_figure(region: Any, verdict: str, request: Request) -> Any:
    """The figure of :func:`ge_region` for an analysis' ``gilbert_elliott`` region (with its map).

    The title starts with the exact verdict at the request's ``(q, p)``, which
    is marked by a star; the critical rates ``q*(p)`` and ``p*(q)`` of the
    request's lines are drawn as ticks on the dashed lines through it.
    """
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    from kfio.stability import GeStructure, boundary_lines

    m = region.map
    rates = np.array(m.rates)
    step = rates[1] - rates[0] if len(rates) > 1 else 1.0
    extent = (0.0, 1.0, 0.0, 1.0)
    codes = np.array([[_EXACT_CODE[x] for x in row] for row in m.labels])  # codes[i][j]: p = rates[i], q = rates[j]
    fig = new_figure()
    ax = fig.subplots()
    cmap = ListedColormap(["#e8a0a0", "#f0f0c0", "#a0d0a0"])
    ax.imshow(codes, origin="lower", extent=extent, cmap=cmap, vmin=-1, vmax=1, interpolation="nearest", aspect="auto")
    handles: list[Any] = [
        Patch(color="#a0d0a0", label="stable (exact)"),
        Patch(color="#e8a0a0", label="unstable (exact)"),
    ]
    colours = ["navy", "darkorange", "purple", "teal", "brown", "black"]
    patterns = region.patterns
    labelled: dict[int, Any] = {}
    for line in boundary_lines(GeStructure(patterns)):
        q, p, which = np.array(line.q), np.array(line.p), np.array(line.pattern)
        if line.closed:
            q, p, which = np.append(q, q[0]), np.append(p, p[0]), np.append(which, which[0])
        cuts = np.flatnonzero(np.diff(which)) + 1
        for lo, hi in zip([0, *cuts], [*cuts, len(q)]):
            k = int(which[lo])
            end = min(hi + 1, len(q))  # runs share their last vertex: the line stays connected
            (drawn,) = ax.plot(q[lo:end], p[lo:end], color=colours[k % len(colours)], lw=1.8, gid=GE_BOUNDARY_GID)
            if k not in labelled:
                piece = patterns[k].describe()
                label = pretty_powers(f"block {', '.join(piece['eigenvalues'])}: {piece['equation']}")
                drawn.set_label(_shorten(label, 60))
                labelled[k] = drawn
    handles.extend(labelled.values())
    p0, q0 = 1 - float(request.channel.table[1]), float(request.channel.table[0])  # type: ignore[union-attr]
    ax.axvline(q0, color="blue", lw=0.6, ls="--")
    ax.axhline(p0, color="blue", lw=0.6, ls="--")
    for c in region.recovery.crossings:
        ax.plot([c.value], [p0], "|", color="blue", ms=10, mew=1.5)
    for c in region.failure.crossings:
        ax.plot([q0], [c.value], "_", color="blue", ms=10, mew=1.5)
    handles.append(ax.scatter([q0], [p0], marker="*", s=160, c="blue", edgecolors="white", zorder=5, label="request"))
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    ax.set_xlabel("recovery rate q = P(arrived | lost)")
    ax.set_ylabel("failure rate p = P(lost | arrived)")
    figure_headline(
        fig,
        f"{_verdict_text(verdict)} at the request (star): q = {q0:.4g}, p = {p0:.4g}\n"
        f"{_critical_text(region)}\n"
        f"Gilbert-Elliott region, n = {request.system.n}: {len(rates)} x {len(rates)} cells of {step:.3g}, "
        "exact per cell; lines: exact boundary",
    )
    legend_outside(ax, handles)
    return fig


def _critical_text(region: Any) -> str:
    """``q*(p0) = ...; p*(q0) = ...`` from the report's exact critical rates (ticks on the dashed lines)."""
    parts = []
    for line, name, at in ((region.recovery, "q*", "p"), (region.failure, "p*", "q")):
        values = ", ".join(f"{c.value:.4g}" for c in line.crossings) or f"none ({line.status()})"
        parts.append(f"{name}({at} = {_short_fraction(line.fixed)}) = {values}")
    return "critical rates (ticks): " + "; ".join(parts)


def _short_fraction(text: str) -> str:
    """Exact rational text, or its decimal when long."""
    if len(text) <= 9:
        return text
    from fractions import Fraction

    return f"{float(Fraction(text)):.6g}"


def _shorten(text: str, width: int) -> str:
    return text if len(text) <= width else text[: width - 3] + "..."
