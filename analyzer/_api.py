"""The Python API: ``kfio.analyze``, ``kfio.bounds``, ``kfio.simulate``, ``kfio.expected_covariance``.

One code path: every function here writes its arguments as the JSON tree of a
request file (:mod:`kfio.model._coerce`), validates it with the same
:func:`kfio.model._request.parse_request` as the CLI and the HTTP service, and
calls the same function they call.  So ``kfio.analyze(sys, ch).to_dict()`` is
the report ``kfio analyze --json`` prints for the same numbers, and an invalid
argument gets the JSON route's message with the Python argument as the field
(``A[0][1]``, ``channel['arrival_probability']``, ``steps``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, Callable, TypeVar

from ._budget import Budget
from ._system import System, plant_of
from .errors import InvalidInput
from .model import (
    DEFAULT_LIMITS,
    Limits,
    Request,
    Route,
    channel_tree,
    json_ready,
    parse_request,
    python_tree,
    renamed,
)

if TYPE_CHECKING:
    from ._typing import BudgetLike, ChannelLike, MatrixLike, StateSpaceLike
    from .riccati_bounds import BoundsReport
    from .simulation import FiniteHorizonReport, SimulationReport
    from .stability import StabilityReport


def _budget_of(budget: Any) -> tuple[Budget | None, Any]:
    """``(Budget object, seconds for options.time_budget_s)``: one of them, or neither."""
    if budget is None or isinstance(budget, Budget):
        return budget, None
    return None, python_tree(budget)


def request_dict(
    system: System | StateSpaceLike,
    channel: ChannelLike,
    *,
    Q: MatrixLike | None = None,
    R: MatrixLike | None = None,
    command: str | None = None,
    options: Mapping[str, Any] | None = None,
    budget: BudgetLike | None = None,
) -> dict[str, Any]:
    """The request file for ``system`` and ``channel``, as a JSON-ready dict.

    ``json.dump`` it and ``kfio <command> FILE`` (or ``POST /v1/<command>``)
    answers exactly what :func:`analyze`, :func:`bounds` or :func:`simulate`
    return for the same arguments.

    Examples
    --------
    >>> from kfio import bernoulli
    >>> request_dict(System(A=[[1.1]], C=[[1]]), bernoulli(0.5), command="analyze", budget=10)
    {'system': {'A': [['11/10']], 'C': [['1']]}, 'channel': {'model': 'bernoulli', 'arrival_probability': '1/2'}, \
'options': {'time_budget_s': 10}}
    """
    tree, _ = _tree(system, channel, command, options, budget, Q=Q, R=R)
    ready: dict[str, Any] = json_ready(tree)
    return ready


def _tree(
    system: Any,
    channel: Any,
    command: str | None,
    options: Any,
    budget: Any,
    keywords: Mapping[str, Any] = {},
    limits: Limits = DEFAULT_LIMITS,
    Q: Any = None,
    R: Any = None,
) -> tuple[dict[str, Any], list[Route]]:
    system = plant_of(system, Q, R, limits=None if isinstance(system, System) else limits)
    ch = channel_tree(channel)
    if not isinstance(ch, dict):
        raise InvalidInput(
            "channel",
            "expected a channel: kfio.bernoulli(p), kfio.gilbert_elliott(...), kfio.markov({...}), "
            f"kfio.per_sensor({{...}}) or a channel's JSON object; got a {type(channel).__name__}",
        )
    tree: dict[str, Any] = {"system": system.to_dict(), "channel": ch}
    routes: list[Route] = []
    opts: dict[str, Any] = {}
    if options is not None or keywords:
        if command is None:
            raise InvalidInput("options", "options need a command")
        if options is not None and not isinstance(options, Mapping):
            raise InvalidInput(
                "options", f"expected a mapping of option names to values; got a {type(options).__name__}"
            )
        group = {**python_tree(dict(options or {})), **{k: python_tree(v) for k, v in keywords.items()}}
        opts[command] = group
        routes += [(f"/options/{command}/{k}", k, group[k], False) for k in keywords]
        routes.append((f"/options/{command}", "options", group, False))
    _, seconds = _budget_of(budget)
    if seconds is not None:
        opts["time_budget_s"] = seconds
        routes.append(("/options/time_budget_s", "budget", seconds, False))
    if opts:
        tree["options"] = opts
    if isinstance(ch, dict) and ch.get("model") == "per_sensor" and isinstance(ch.get("channels"), dict):
        routes.append(("/channel/channels", "channel", ch["channels"], False))
    routes += [("/options", "options", opts, False), ("/channel", "channel", ch, False)]
    routes.append(("/system", "system", tree["system"], True))
    return tree, routes


def build_request(
    system: System | StateSpaceLike | Request,
    channel: ChannelLike | None = None,
    *,
    Q: MatrixLike | None = None,
    R: MatrixLike | None = None,
    command: str | None = None,
    options: Mapping[str, Any] | None = None,
    budget: BudgetLike | None = None,
    limits: Limits | None = None,
) -> Request:
    """The validated :class:`kfio.Request` that the JSON route builds from the same values.

    ``load_request(json.dumps(request_dict(...)))`` gives the same request:
    one validator (:func:`kfio.parse_request`) for every surface.  A
    :class:`Request` passes through unchanged.  ``command`` names the
    ``options`` group (``"analyze"``, ``"bounds"``, ``"simulate"``); budget
    seconds become ``request.time_budget_s`` (a :class:`kfio.Budget` object
    is not part of a request: pass it to :func:`analyze` and friends).
    ``limits`` default to those the :class:`System` was built with, as
    :meth:`kfio.Limits.for_command` of ``command`` gives them (``analyze``
    accepts more states than the other commands).

    Examples
    --------
    >>> import kfio
    >>> req = kfio.build_request(kfio.System(A=[[1.1]], C=[[1]]), kfio.bernoulli(0.5), budget=10)
    >>> req.channel.table, req.time_budget_s
    ((Fraction(1, 2),), 10.0)
    """
    request, _, _ = _build_request(
        system, channel, Q=Q, R=R, command=command, options=options, budget=budget, limits=limits
    )
    return request


def _build_request(
    system: Any,
    channel: Any = None,
    *,
    Q: Any = None,
    R: Any = None,
    command: str | None = None,
    options: Mapping[str, Any] | None = None,
    budget: Any = None,
    limits: Limits | None = None,
    keywords: Mapping[str, Any] | None = None,
) -> tuple[Request, Budget | None, list[Route]]:
    """:func:`build_request`, with the :class:`~kfio.Budget` object if one was given and the routes
    that rename later errors to Python arguments."""
    if isinstance(system, Request):
        if channel is not None or options is not None or keywords:
            raise InvalidInput("channel", "a validated Request already holds its channel and options")
        for name, value in (("Q", Q), ("R", R)):
            if value is not None:
                raise InvalidInput(name, f"a validated Request already holds its system: {name} belongs in it")
        work, seconds = _budget_of(budget)
        if seconds is not None:
            work = Budget(seconds=float(python_tree(seconds)))
        return system, work, []
    if channel is None:
        raise InvalidInput("channel", "a channel is required, e.g. kfio.bernoulli(0.5)")
    if limits is None:
        limits = getattr(system, "_limits", DEFAULT_LIMITS)
    tree, routes = _tree(system, channel, command, options, budget, keywords or {}, limits, Q, R)
    work, _ = _budget_of(budget)
    try:
        return parse_request(tree, limits.for_command(command)), work, routes
    except InvalidInput as exc:
        raise renamed(exc, routes) from None


_R = TypeVar("_R")


def _run(fn: Callable[..., _R], routes: Sequence[Route], *args: Any, **kwargs: Any) -> _R:
    try:
        return fn(*args, **kwargs)
    except InvalidInput as exc:
        raise renamed(exc, routes) from None


def analyze(
    system: System | StateSpaceLike | Request,
    channel: ChannelLike | None = None,
    *,
    Q: MatrixLike | None = None,
    R: MatrixLike | None = None,
    options: Mapping[str, Any] | None = None,
    budget: BudgetLike | None = None,
) -> StabilityReport:
    """Decide whether the Kalman filter's expected error covariance stays bounded.

    The exact verdict of Rohr, Marelli and Fu (2014), Theorem 1: bounded iff
    ``|alpha_k|^2 sigma_k < 1`` for every FMO block ``k`` (groups of
    eigenvalues of ``A`` of one modulus whose ratios are roots of unity),
    where ``sigma_k`` is the per-step rate at which the probability of
    staying blind to block ``k`` decays; unbounded if ``> 1`` for some block;
    ``boundary`` at equality.  For a Bernoulli channel the report also gives
    the exact critical arrival probability.

    Parameters
    ----------
    system:
        A :class:`System`, a discrete-time python-control ``StateSpace``
        (its ``A`` and ``C``; ``Q`` and ``R`` as keywords), or a validated
        request (the CLI's and the service's entry: ``analyze(load_request(text))``).
    Q, R:
        The noise covariances where ``system`` has none (a ``StateSpace``, or
        a :class:`System` built without them); a keyword for a matrix the
        system already has is refused, naming it.
    channel:
        :func:`kfio.bernoulli`, :func:`kfio.gilbert_elliott`,
        :func:`kfio.markov`, :func:`kfio.per_sensor`, or a channel's JSON object.
    options:
        ``options.analyze`` of a request: ``ge_grid`` (integer 2..101, a
        Gilbert-Elliott channel only) adds the exact (p, q) map;
        ``critical_parameter`` (a JSON pointer such as
        ``"/channel/recovery_rate"``) adds the exact critical value of that
        one probability, the others fixed.  The README's options table lists
        every option of every command.
    budget:
        Seconds (as ``options.time_budget_s``, in ``[0.01, 3600]``) or a
        :class:`kfio.Budget`; default 120 s.

    Returns
    -------
    StabilityReport
        ``verdict``, ``critical_arrival_probability``, ``blocks[k].sigma``, ...;
        ``to_dict()`` is the JSON of ``kfio analyze --json``.

    Raises
    ------
    InvalidInput, AssumptionViolation
        A bad argument (named), or a channel probability of 0 or 1 (Rohr,
        Marelli and Fu 2014, Assumption 1).
    BudgetExceeded
        The computation did not fit the budget.

    Examples
    --------
    >>> import kfio, numpy as np
    >>> sys = kfio.System(A=np.array([[1.25, 0], [1, 1.1]]), C=[[1, 1]], Q=20 * np.eye(2), R=[[2.5]])
    >>> r = kfio.analyze(sys, kfio.bernoulli(0.5))
    >>> r.verdict, r.critical_arrival_probability_exact, r.blocks[0].sigma
    ('stable', '9/25', 0.5)
    """
    from .stability import analyze as _analyze

    request, work, routes = _build_request(system, channel, Q=Q, R=R, command="analyze", options=options, budget=budget)
    return _run(_analyze, routes, request, budget=work)


def bounds(
    system: System | StateSpaceLike | Request,
    channel: ChannelLike | None = None,
    *,
    Q: MatrixLike | None = None,
    R: MatrixLike | None = None,
    options: Mapping[str, Any] | None = None,
    budget: BudgetLike | None = None,
) -> BoundsReport:
    """Bounds on the critical arrival probability and on ``lim E[P_t]``.

    Sinopoli et al. (2004), Theorems 3-5 (``S_bar <= lim E[P_t] <= V_bar``,
    ``lambda_lower <= lambda_c <= lambda_upper`` from an LMI whose certificate
    is re-checked exactly), Liu and Goldsmith (2004) for several sensors, and
    the ``P_hat_N`` sequence of Rohr, Marelli and Fu (2010) for one packet.
    Needs ``Q`` and ``R`` and i.i.d. (Bernoulli) channels.  Imports CVXPY.

    Parameters
    ----------
    system, channel, Q, R, budget:
        As in :func:`analyze`.
    options:
        ``options.bounds`` of a request: ``tolerance``, ``horizon``, ``grid``,
        ``arrival_probability``, ``trace_target``, ``sdp_cross_check``.

    Returns
    -------
    BoundsReport
        ``to_dict()`` is the JSON of ``kfio bounds --json``.

    Examples
    --------
    >>> import kfio
    >>> b = kfio.bounds(kfio.System(A=[[-1.25]], C=[[1]], Q=[[1]], R=[[2.5]]), kfio.bernoulli(0.4))
    >>> round(b.critical[0].lower, 9), b.verdict
    (0.36, 'stable')
    """
    from .riccati_bounds import compute_bounds

    request, work, routes = _build_request(system, channel, Q=Q, R=R, command="bounds", options=options, budget=budget)
    return _run(compute_bounds, routes, request, work)


def simulate(
    system: System | StateSpaceLike | Request,
    channel: ChannelLike | None = None,
    *,
    Q: MatrixLike | None = None,
    R: MatrixLike | None = None,
    steps: int | None = None,
    trajectories: int | None = None,
    seed: int | None = None,
    exact_steps: int | None = None,
    P0: MatrixLike | None = None,
    initial_channel: str | None = None,
    options: Mapping[str, Any] | None = None,
    budget: BudgetLike | None = None,
) -> SimulationReport:
    """Monte Carlo of the error covariance ``P_t`` of the intermittent Kalman filter.

    Runs the random Riccati recursion (Rohr, Marelli and Fu 2014, eq. (2))
    along random arrival sequences and reports ``trace(P_t)``: mean with a
    95% band, median, 90% and 99% percentiles; with ``exact_steps`` also the
    exact ``E[P_t]`` (see :func:`expected_covariance`) to compare with.

    Parameters
    ----------
    system, channel, Q, R, budget:
        As in :func:`analyze`; ``Q`` and ``R`` are needed.
    steps, trajectories, seed, exact_steps, P0, initial_channel:
        The keys of ``options.simulate`` (defaults: 200 steps, as many
        trajectories as the work cap allows, seed 0, ``P0 = Q``, stationary
        channel); a keyword wins over the same key in ``options``, as the
        CLI's flags do.
    options:
        ``options.simulate`` of a request: the keys above and
        ``percentiles``, ``outage_thresholds``, ``outage_target``.

    Returns
    -------
    SimulationReport
        ``to_dict()`` is the JSON of ``kfio simulate --json``.

    Examples
    --------
    >>> import kfio
    >>> sys = kfio.System(A=[[1.2]], C=[[1]], Q=[[1]], R=[[1]])
    >>> rep = kfio.simulate(sys, kfio.bernoulli(0.5), steps=20, trajectories=1000, seed=1)
    >>> rep.mean_trace.shape, rep.mean_diverged_at
    ((21,), None)
    """
    from .simulation import simulate as _simulate

    given = dict(
        steps=steps,
        trajectories=trajectories,
        seed=seed,
        exact_steps=exact_steps,
        P0=P0,
        initial_channel=initial_channel,
    )
    keywords = {k: v for k, v in given.items() if v is not None}
    request, work, routes = _build_request(
        system, channel, Q=Q, R=R, command="simulate", options=options, budget=budget, keywords=keywords
    )
    return _run(_simulate, routes, request, work)


def expected_covariance(
    system: System | StateSpaceLike | Request,
    channel: ChannelLike | int | None = None,
    steps: int | None = None,
    *,
    Q: MatrixLike | None = None,
    R: MatrixLike | None = None,
    P0: MatrixLike | None = None,
    initial_channel: str | None = None,
    budget: BudgetLike | None = None,
) -> FiniteHorizonReport:
    """The exact ``E[P_t]``, ``t = 0..steps``, by summing over every arrival sequence.

    ``E[P_t] = sum_g P(g) P_t(g)`` over the ``2^(m t)`` arrival sequences
    ``g`` of ``m`` packets (Rohr, Marelli and Fu 2014, eq. (7)), with the
    Markov channel's probabilities; exact up to float rounding of the
    Riccati steps.  For short horizons: ``2^(m steps)`` is limited.

    Parameters
    ----------
    system, channel, Q, R, budget:
        As in :func:`analyze`; ``Q`` and ``R`` are needed.  With a validated
        request (which carries its channel), the horizon may come second:
        ``expected_covariance(request, 4)`` or ``expected_covariance(request, steps=4)``.
    steps:
        Horizon ``T >= 0`` (required).
    P0, initial_channel:
        Initial covariance (default ``Q``) and channel history before
        ``t = 0`` (``"stationary"``, ``"all_lost"`` or ``"all_arrived"``).

    Examples
    --------
    Scalar ``a = 2``, ``lambda = 1/2``, ``P_0 = Q = R = 1``:
    ``E[P_1] = (1/2)(4 + 1) + (1/2)(4 - 4/2 + 1) = 4``.

    >>> import kfio
    >>> rep = kfio.expected_covariance(kfio.System(A=[[2]], C=[[1]], Q=[[1]], R=[[1]]), kfio.bernoulli(0.5), 1)
    >>> float(rep.mean_trace[1])
    4.0
    """
    from .simulation import expected_covariance as _expected

    if isinstance(system, Request) and steps is None and isinstance(channel, int) and not isinstance(channel, bool):
        channel, steps = None, channel  # expected_covariance(request, steps)
    if steps is None:
        raise InvalidInput("steps", "the horizon is required: expected_covariance(system, channel, steps)")
    keywords = {k: v for k, v in dict(P0=P0, initial_channel=initial_channel).items() if v is not None}
    request, work, routes = _build_request(
        system, channel, Q=Q, R=R, command="simulate", budget=budget, keywords=keywords
    )
    routes = [("/options/simulate/exact_steps", "steps", steps, False), *routes]
    return _run(_expected, routes, request, python_tree(steps), work)


__all__ = ["System", "analyze", "bounds", "build_request", "expected_covariance", "request_dict", "simulate"]
