"""``kfio.loop(...)``: the Python door of ``kfio loop``, typed, with the gains named by their role.

One code path, as for :func:`kfio.analyze`: the arguments are written as the
JSON tree of a loop request file (:func:`loop_request`), validated by
:func:`kfio.loop.parse_loop_request` like the file of ``kfio loop`` and the
body of ``POST /v1/loop``, and analyzed by :func:`kfio.loop.analyze_loop`.
An invalid argument is named as the Python argument (``feedback[0][1]``,
``actuator_channel['arrival_probability']``), with the validator's rule.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, Literal

from .._budget import Budget
from ..errors import InvalidInput
from ..model import Route, channel_tree, json_ready, python_tree, renamed
from ._model import LoopRequest, parse_loop_request
from ._report import LoopReport, analyze_loop

if TYPE_CHECKING:
    from .._system import System
    from .._typing import BudgetLike, ChannelLike, MatrixLike, StateSpaceLike


def loop(
    system: System | StateSpaceLike | Mapping[str, Any] | LoopRequest,
    *,
    feedback: MatrixLike | None = None,
    estimator: MatrixLike | None = None,
    form: Literal["predictor", "filter"] | None = None,
    lqg: Mapping[str, MatrixLike] | None = None,
    channel: ChannelLike | None = None,
    actuator_channel: ChannelLike | None = None,
    B: MatrixLike | None = None,
    Q: MatrixLike | None = None,
    R: MatrixLike | None = None,
    cost: Mapping[str, MatrixLike] | None = None,
    options: Mapping[str, Any] | None = None,
    budget: BudgetLike | None = None,
) -> LoopReport:
    """Exact mean-square stability, cost and critical link reliabilities of a loop closed over lossy links.

    The plant ``x[t+1] = A x + B a + w``, ``y = C x + v`` is observed through
    the sensor packets (``channel``) and actuated through the actuator packets
    (``actuator_channel``) under ``u = -F x_hat``, ``F = feedback``, with the
    estimator gain ``estimator`` (Schenato, Sinopoli, Franceschetti, Poolla
    and Sastry 2007, Sec. II, who write ``L`` for ``F`` and ``K`` for the
    estimator gain).  The loop is a Markov jump linear system, mean-square
    stable iff the spectral radius of its second-moment operator is below 1
    (Costa, Fragoso and Marques 2005, Thm 3.9), decided exactly over Q.

    Parameters
    ----------
    system:
        A discrete-time python-control ``StateSpace`` (``A``, ``B``, ``C``;
        ``Q`` and ``R`` as keywords), a :class:`kfio.System` with ``Q`` and
        ``R`` (then ``B`` is required; ``Q`` and ``R`` as keywords only where
        the System has none), a loop request (the dict of a
        ``kfio loop`` file; then only ``budget`` may be given), or a
        validated :class:`kfio.loop.LoopRequest`.
    feedback:
        ``F`` (``m x n``) of ``u = -F x_hat``: python-control's ``dlqr`` ``K``.
    estimator:
        The estimator gain (``n x p``): python-control's ``dlqe`` ``L`` in
        ``"predictor"`` form (the default, ``eig(A - E C)``), or the gain of
        the measurement update in ``"filter"`` form (``form``).
    lqg:
        ``{"W": ..., "U": ...}`` instead of the gains: kfio computes the
        stationary TCP-like LQG gains (docs/loop.md).
    channel, actuator_channel:
        The sensor packets' channel (any kfio channel) and the actuator
        packets' (Bernoulli, Gilbert-Elliott or Markov), e.g. ``kfio.bernoulli(0.9)``.
    B, Q, R:
        The input matrix (with a :class:`kfio.System`) and the noise
        covariances (with a ``StateSpace``, or a System without them; a
        keyword for a matrix the System already has is refused, naming it).
    cost:
        ``{"W": ..., "U": ...}`` weighing ``x' W x + a' U a`` (default ``W = I``, ``U = 0``).
    options:
        ``options.loop`` of a request: ``protocol`` (``"tcp"`` or ``"udp"``),
        ``on_loss`` (``"zero"`` or ``"hold"``), ``region`` (grid points).
    budget:
        Seconds (as ``options.time_budget_s``, in ``[0.01, 3600]``) or a
        :class:`kfio.Budget`: the verdict raises
        :class:`kfio.errors.BudgetExceeded` if it does not fit; later parts
        are left out of a ``partial`` report.

    Returns
    -------
    LoopReport
        ``to_dict()`` is the JSON of ``kfio loop --json`` for :func:`loop_request` of the same arguments.

    Raises
    ------
    InvalidInput
        A bad argument, named (``feedback``, ``channel['arrival_probability']``, ...).

    Examples
    --------
    >>> import kfio
    >>> plant = kfio.System(A=[[1.25]], C=[[1]], Q=[[1]], R=[[0.5]])
    >>> r = kfio.loop(plant, B=[[1]], feedback=[[0.6]], estimator=[[0.5]],
    ...               channel=kfio.bernoulli(0.8), actuator_channel=kfio.bernoulli(0.9))
    >>> r.verdict, r.critical_sensor_arrival_probability_exact, r.critical_actuator_arrival_probability_exact
    ('stable', '9/16', '75/152')
    """
    work = budget if isinstance(budget, Budget) else None
    if isinstance(system, LoopRequest):
        _only_budget(feedback, estimator, form, lqg, channel, actuator_channel, B, Q, R, cost, options)
        return analyze_loop(system, budget=work if work is not None else _seconds(budget))
    tree, routes = _request_tree(
        system, feedback, estimator, form, lqg, channel, actuator_channel, B, Q, R, cost, options, budget
    )
    try:
        request = parse_loop_request(tree)
    except InvalidInput as exc:
        raise renamed(exc, routes) from None
    return analyze_loop(request, budget=work)


def loop_request(
    system: System | StateSpaceLike | Mapping[str, Any],
    *,
    feedback: MatrixLike | None = None,
    estimator: MatrixLike | None = None,
    form: Literal["predictor", "filter"] | None = None,
    lqg: Mapping[str, MatrixLike] | None = None,
    channel: ChannelLike | None = None,
    actuator_channel: ChannelLike | None = None,
    B: MatrixLike | None = None,
    Q: MatrixLike | None = None,
    R: MatrixLike | None = None,
    cost: Mapping[str, MatrixLike] | None = None,
    options: Mapping[str, Any] | None = None,
    budget: BudgetLike | None = None,
) -> dict[str, Any]:
    """The loop request file (a JSON-ready dict) for the arguments of :func:`loop` (``budget`` in seconds).

    ``json.dump`` it and ``kfio loop FILE`` (or ``POST /v1/loop``) answers
    what :func:`loop` returns for the same arguments.

    Examples
    --------
    >>> import kfio
    >>> tree = loop_request(kfio.System(A=[[1.25]], C=[[1]], Q=[[1]], R=[[0.5]]), B=[[1]],
    ...                     feedback=[[0.6]], estimator=[[0.5]], channel=kfio.bernoulli(0.8),
    ...                     actuator_channel=kfio.bernoulli(0.9))
    >>> tree["controller"]
    {'gains': {'feedback': [['0.6']], 'estimator': [['0.5']]}}
    """
    tree, _ = _request_tree(
        system, feedback, estimator, form, lqg, channel, actuator_channel, B, Q, R, cost, options, budget
    )
    return tree


def _seconds(budget: Any) -> Budget | None:
    return None if budget is None else Budget(seconds=float(python_tree(budget)))


def _only_budget(*given: Any) -> None:
    if any(g is not None for g in given):
        raise InvalidInput("system", "a loop request already holds its gains, channels and options: pass only budget")


def _request_tree(
    system: Any,
    feedback: Any,
    estimator: Any,
    form: Any,
    lqg: Any,
    channel: Any,
    actuator_channel: Any,
    B: Any,
    Q: Any,
    R: Any,
    cost: Any,
    options: Any,
    budget: Any,
) -> tuple[dict[str, Any], list[Route]]:
    """The request's JSON tree and the routes that name its fields as the Python arguments."""
    from .._system import System, is_statespace, plant_of

    seconds = None if budget is None or isinstance(budget, Budget) else python_tree(budget)
    if isinstance(system, Mapping):
        _only_budget(feedback, estimator, form, lqg, channel, actuator_channel, B, Q, R, cost, options)
        given = dict(python_tree(dict(system)))
        if seconds is not None:
            given["options"] = {**given.get("options", {}), "time_budget_s": seconds}
        return json_ready(given), []
    keywords = {"B": B, "Q": Q, "R": R}  # the plant's matrices that come as keywords, named so in errors
    if isinstance(system, System):
        if B is None:
            raise InvalidInput("B", "a loop needs the input matrix B (or pass a python-control StateSpace)")
        sys_tree = plant_of(system, Q, R).to_dict()
        sys_tree["B"] = python_tree(B)
    elif is_statespace(system):
        sys_tree = plant_of(system, Q, R).to_dict()
        sys_tree["B"] = python_tree(system.B if B is None else B)
        keywords = {"B": B, "Q": Q if Q is not None else "", "R": R if R is not None else ""}
    else:
        raise InvalidInput(
            "system",
            f"expected a python-control StateSpace, a kfio.System or a loop request; got a {type(system).__name__}",
        )
    for name, value in (("channel", channel), ("actuator_channel", actuator_channel)):
        if value is None:
            raise InvalidInput(name, f"{name} is required, e.g. kfio.bernoulli(0.9)")
    controller: dict[str, Any]
    if lqg is not None:
        if feedback is not None or estimator is not None or form is not None:
            raise InvalidInput("lqg", "give either lqg weights or the gains feedback and estimator, not both")
        controller = {"lqg": python_tree(dict(lqg))}
    else:
        for name, value in (("feedback", feedback), ("estimator", estimator)):
            if value is None:
                raise InvalidInput(name, f"{name} is required (or lqg weights): {_ROLES}")
        controller = {"gains": {"feedback": python_tree(feedback), "estimator": python_tree(estimator)}}
        if form is not None:
            controller["form"] = form
    tree: dict[str, Any] = {
        "system": sys_tree,
        "channel": channel_tree(channel, bernoulli_number=True),
        "actuator_channel": channel_tree(actuator_channel, bernoulli_number=True),
        "controller": controller,
    }
    if cost is not None:
        tree["cost"] = python_tree(dict(cost))
    opts: dict[str, Any] = {}
    if options is not None:
        opts["loop"] = python_tree(dict(options))
    if seconds is not None:
        opts["time_budget_s"] = seconds
    if opts:
        tree["options"] = opts
    tree = json_ready(tree)
    routes: list[Route] = [
        ("/controller/gains/feedback", "feedback", tree["controller"].get("gains", {}).get("feedback"), False),
        ("/controller/gains/estimator", "estimator", tree["controller"].get("gains", {}).get("estimator"), False),
        ("/controller/form", "form", form, False),
        ("/controller/lqg", "lqg", tree["controller"].get("lqg"), False),
        ("/actuator_channel", "actuator_channel", tree["actuator_channel"], False),
        ("/channel", "channel", tree["channel"], False),
        ("/cost", "cost", tree.get("cost"), False),
        ("/options/loop", "options", tree.get("options", {}).get("loop"), False),
        ("/options/time_budget_s", "budget", seconds, False),
    ]
    routes += [(f"/system/{k}", k, tree["system"].get(k), False) for k, v in keywords.items() if v is not None]
    routes.append(("/system", "system", tree["system"], True))
    return tree, routes


_ROLES = "feedback is F of u = -F x_hat (python-control's dlqr K), estimator the estimator gain (dlqe's L)"

__all__ = ["loop", "loop_request"]
