"""What arrival probability keeps the estimated outage ``P(trace P > M)`` below ``epsilon``?  (One Bernoulli packet.)

``options.simulate.outage_target: {"threshold": M, "epsilon": e}`` asks for
the smallest arrival probability ``lambda`` at which the stationary outage
probability of the predictor, ``P(trace P_T > M)`` (estimated as in
:mod:`kfio.simulation._stationary`, one sample of ``P_T`` per trajectory; Kar,
Sinopoli and Moura 2012 for the convergence in distribution), is at most
``e``.

Common random numbers make the estimate monotone.  Every probe reruns the
simulation with the request's seed, so the uniforms ``U_{i,t}`` are the same
and packet ``t`` of trajectory ``i`` arrives iff ``U_{i,t} < lambda``: the
arrival sets grow with ``lambda``.  The Riccati map is monotone in ``P`` and
an arrival never increases it (``Phi_1(P) <= Phi_0(P)``; Sinopoli et al.
2004, Lemma 1), so every trajectory's ``P_T`` decreases with ``lambda``, and so
do the outage count, its estimate and both ends of its Wilson 95% interval.
Three bisections over ``lambda`` in ``[0, 1]`` then give

* ``estimate``: where the estimated outage first is at most ``e``;
* ``bracket = [confidently_insufficient, confidently_sufficient]``: below the
  first the whole interval lies above ``e``; from the second on it lies at
  or below ``e``.  Between them the interval straddles ``e``: the simulation
  cannot tell.

Each end is known to the bisection tolerance.  All of it is ``estimated``:
a Monte Carlo answer with sampling error, for one seed and horizon, not a
certificate.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Callable

import numpy as np

from .._budget import Budget
from .._reporting import ReportPart
from ..errors import InvalidInput
from ..model import Request, option_field, parse_number
from ._setup import SimSystem, SimulateOptions
from ._stationary import wilson

_TARGET = option_field("simulate", "outage_target")
FIELD = _TARGET.pointer
DEFAULT_TOLERANCE = float(_TARGET.prop("tolerance").default)
_KEYS = tuple(p.name for p in _TARGET.properties)


@dataclass(frozen=True)
class OutageTargetSpec:
    threshold: float
    epsilon: float
    tolerance: float


def parse_outage_target(request: Request) -> OutageTargetSpec | None:
    """``options.simulate.outage_target`` or ``None``.

    Raises
    ------
    InvalidInput
        Naming ``/options/simulate/outage_target`` or one of its keys: not an
        object, unknown key, ``threshold <= 0``, ``epsilon`` outside ``(0, 1)``,
        ``tolerance`` outside ``(0, 1/4]``, or a channel other than one
        Bernoulli packet.
    """
    raw = request.options.get("simulate", {}).get("outage_target")
    if raw is None:
        return None
    if not isinstance(raw, dict):
        raise InvalidInput(FIELD, 'outage_target must be an object {"threshold": M, "epsilon": e}')
    for key in raw:
        if key not in _KEYS:
            raise InvalidInput(f"{FIELD}/{str(key)[:64]}", f"unknown key; allowed: {', '.join(_KEYS)}")
    for key in _TARGET.required:
        if key not in raw:
            raise InvalidInput(f"{FIELD}/{key}", f"outage_target needs {key!r}")
    m = parse_number(raw["threshold"], f"{FIELD}/threshold")
    if not _TARGET.prop("threshold").admits(m):
        raise InvalidInput(f"{FIELD}/threshold", "the outage threshold M must be positive")
    e = parse_number(raw["epsilon"], f"{FIELD}/epsilon")
    if not _TARGET.prop("epsilon").admits(e):
        raise InvalidInput(f"{FIELD}/epsilon", "epsilon must lie strictly between 0 and 1")
    tol = (
        parse_number(raw["tolerance"], f"{FIELD}/tolerance")
        if "tolerance" in raw
        else _TARGET.prop("tolerance").default
    )
    if not _TARGET.prop("tolerance").admits(tol):
        raise InvalidInput(f"{FIELD}/tolerance", "tolerance must lie in (0, 1/4]")
    ch = request.channel
    if getattr(ch, "model", None) != "bernoulli" or request.system.sensors and len(request.system.sensors) > 1:
        raise InvalidInput(FIELD, "outage_target needs one Bernoulli packet (channel.model 'bernoulli')")
    return OutageTargetSpec(float(m), float(e), float(tol))


@dataclass(frozen=True)
class OutageTarget(ReportPart):
    """The smallest ``lambda`` with estimated ``P(trace P_T > M) <= epsilon``; see the module docstring.

    Attributes
    ----------
    estimate:
        Smallest probed ``lambda`` (to ``tolerance``) whose outage estimate is
        at most ``epsilon``; ``None`` if not even ``lambda = 1`` meets it.
    insufficient, sufficient:
        The bracket: below ``insufficient`` the 95% interval lies above
        ``epsilon``; at ``sufficient`` it lies at or below.  ``None`` where no
        probe in ``[0, 1]`` has that property.
    probes:
        ``(lambda, outage, low, high)`` of every simulation run, sorted.
    """

    threshold: float
    epsilon: float
    tolerance: float
    steps: int
    trajectories: int
    seed: int
    estimate: float | None
    insufficient: float | None
    sufficient: float | None
    probes: tuple[tuple[float, float, float, float], ...]

    def summary_lines(self) -> list[str]:
        """One line: the estimate and its bracket, or plainly why the target cannot be reached."""
        head = (
            f"outage target P(trace P > {self.threshold:g}) <= {self.epsilon:g} (estimated, {self.trajectories} "
            f"trajectories x {self.steps} steps): "
        )
        if self.estimate is None:
            at_one = [o for lam, o, _, _ in self.probes if lam == 1.0]
            seen = f" (estimated outage {at_one[0]:.4g})" if at_one else ""
            return [
                head + "cannot be reached for any lambda in [0, 1]: even when every packet arrives (lambda = 1) "
                f"the outage exceeds {self.epsilon:g}{seen}, so the threshold {self.threshold:g} lies below the "
                "trace the filter settles at without losses"
            ]
        if self.estimate == 0.0:
            return [head + "met at every lambda in [0, 1], even lambda = 0 (no packet arrives)"]
        if self.insufficient is not None and self.sufficient is not None:
            bracket = (
                f"the 95% interval straddles epsilon between lambda = {self.insufficient:.4g} and {self.sufficient:.4g}"
            )
        elif self.sufficient is not None:
            bracket = f"the 95% interval lies at or below epsilon from lambda = {self.sufficient:.4g}; no probe has it wholly above"
        elif self.insufficient is not None:
            bracket = f"the 95% interval lies above epsilon below lambda = {self.insufficient:.4g}; no probe has it wholly at or below"
        else:
            bracket = "the 95% interval contains epsilon at every probe: more trajectories would narrow it"
        return [head + f"smallest lambda about {self.estimate:.4g}; {bracket}"]


def _first_true(test: Callable[[float], bool], tol: float) -> float | None:
    """Smallest ``lambda`` in ``[0, 1]`` (to ``tol``) with ``test`` true, for a test monotone in ``lambda``."""
    if test(0.0):
        return 0.0
    if not test(1.0):
        return None
    lo, hi = 0.0, 1.0
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if test(mid) else (mid, hi)
    return hi


def outage_target(
    sim: SimSystem,
    opts: SimulateOptions,
    spec: OutageTargetSpec,
    run: Callable[..., Any],
    budget: Budget | None = None,
) -> OutageTarget:
    """Bisect ``lambda`` for ``P(trace P_T > M) <= epsilon`` (estimated); see the module docstring.

    ``run`` is :func:`kfio.simulation._simulate.run_monte_carlo` (passed in to
    avoid an import cycle); every probe uses ``opts.seed`` and records the predictor only.
    """
    (pk,) = sim.packets
    cache: dict[float, tuple[float, float, float]] = {}

    def probe(lam: float) -> tuple[float, float, float]:
        if lam not in cache:
            ch = dataclasses.replace(pk.channel, table=(Fraction(lam),))
            s = dataclasses.replace(sim, packets=(dataclasses.replace(pk, channel=ch),))
            x = run(s, opts, budget, filtered=False).final_traces
            k, n = int(np.sum(~(x <= spec.threshold))), x.size
            cache[lam] = (k / n, *wilson(k, n))
        return cache[lam]

    eps, tol = spec.epsilon, spec.tolerance
    estimate = _first_true(lambda lam: probe(lam)[0] <= eps, tol)
    sufficient = _first_true(lambda lam: probe(lam)[2] <= eps, tol)
    not_above = _first_true(lambda lam: probe(lam)[1] <= eps, tol)
    probes = tuple(sorted((lam, *v) for lam, v in cache.items()))
    return OutageTarget(
        spec.threshold,
        eps,
        tol,
        opts.steps,
        opts.trajectories,
        opts.seed,
        estimate,
        not_above,
        sufficient,
        probes,
    )


__all__ = ["OutageTarget", "OutageTargetSpec", "outage_target", "parse_outage_target"]
