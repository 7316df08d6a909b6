"""What arrival probability does a covariance target need?  (One Bernoulli packet.)

``options.bounds.trace_target: T`` asks for the smallest arrival probability
``lambda`` at which the certified upper bound ``trace(V_bar)`` of Sinopoli et
al. (2004, Theorem 4) is at most ``T``.  ``V_bar(lambda)`` is the fixed point
of the modified algebraic Riccati equation ``g_lambda``; since ``g_lambda(X)``
decreases in ``lambda`` for every ``X``, the fixed point does too (the same
paper, Theorem 6 / Lemma 1), so ``trace V_bar(lambda)`` is decreasing and a
bisection finds the threshold.  Every probe solves the MARE with
:func:`kfio.riccati_bounds._riccati.solve_v_bar`, which brackets ``V_bar`` between the
monotone iterate from 0 and a Newton iterate from above and checks the MARE
residual; the test at each probe is ``trace(upper end) <= T``, so a
``sufficient`` probability is one where the bound is met with certainty up to
rounding.  Below ``1 - 1/rho(A)^2`` no ``V_bar`` exists (``S_bar`` diverges).

The answer is a bracket ``[insufficient, sufficient]`` of width at most the
bisection tolerance: ``sufficient`` meets the target, ``insufficient`` does
not (or ``V_bar`` does not exist there).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._budget import Budget
from .._reporting import ReportPart
from ..errors import InvalidInput
from ..model import Request, option_field, parse_number
from ._riccati import one_packet_model, solve_v_bar, spectral_radius

_TRACE_TARGET = option_field("bounds", "trace_target")
FIELD = _TRACE_TARGET.pointer


def parse_trace_target(request: Request) -> float | None:
    """``options.bounds.trace_target`` as a positive float, or ``None``.

    Raises
    ------
    InvalidInput
        Naming ``/options/bounds/trace_target``.
    """
    raw = request.options.get("bounds", {}).get("trace_target")
    if raw is None:
        return None
    value = parse_number(raw, FIELD)
    if not _TRACE_TARGET.admits(value):
        raise InvalidInput(FIELD, "trace_target must be positive")
    return float(value)


@dataclass(frozen=True)
class TraceTarget(ReportPart):
    """The smallest ``lambda`` with certified ``trace(V_bar) <= target``.

    Attributes
    ----------
    target:
        ``T``.
    sufficient, insufficient:
        Bisection bracket: ``trace V_bar(sufficient) <= T`` (certified upper
        end), and at ``insufficient`` not (or ``V_bar`` does not exist);
        ``None`` if even ``lambda`` near 1 does not meet ``T``.
    trace_at_sufficient:
        ``trace V_bar`` at ``sufficient``.
    probes:
        MARE solves used.
    reachable:
        Whether ``T`` is above ``trace V_bar`` as ``lambda -> 1`` (the Kalman
        filter's own ``trace P``).
    """

    target: float
    sufficient: float | None
    insufficient: float
    trace_at_sufficient: float | None
    probes: int
    reachable: bool

    def summary_line(self) -> str:
        if self.sufficient is None:
            return f"trace(V_bar) <= {self.target:g}: not reachable for any arrival probability below 1"
        return (
            f"smallest arrival probability with certified trace(V_bar) <= {self.target:g}: "
            f"{self.sufficient:.6g} (bracket [{self.insufficient:.6g}, {self.sufficient:.6g}], "
            f"trace there {self.trace_at_sufficient:.6g})"
        )


def _trace_upper(
    A: np.ndarray, C: np.ndarray, Q: np.ndarray, R: np.ndarray, lam: float, budget: Budget | None
) -> float | None:
    it = solve_v_bar(one_packet_model(A, C, Q, R, lam), budget=budget)
    return None if it.matrix is None else float(np.trace(it.matrix))


def smallest_arrival_for_trace(
    A: np.ndarray,
    C: np.ndarray,
    Q: np.ndarray,
    R: np.ndarray,
    target: float,
    tol: float = 1e-6,
    budget: Budget | None = None,
) -> TraceTarget:
    """Bisection for the smallest ``lambda`` with ``trace V_bar(lambda) <= target`` (Sinopoli et al. 2004).

    Examples
    --------
    Scalar ``A = -1.25``, ``C = Q = 1``, ``R = 2.5``: ``V_bar`` solves
    ``V = a^2 V + 1 - lambda a^2 V^2 / (V + 2.5)``.

    >>> import numpy as np
    >>> from kfio.riccati_bounds._targets import smallest_arrival_for_trace
    >>> one = lambda x: np.array([[x]])
    >>> t = smallest_arrival_for_trace(one(-1.25), one(1.0), one(1.0), one(2.5), 10.0)
    >>> round(t.sufficient, 5), t.trace_at_sufficient <= 10.0
    (0.53, True)
    """
    rho = spectral_radius(A)
    lo = max(0.0, 1.0 - 1.0 / rho**2) if rho > 0 else 0.0
    hi = 1.0 - 1e-9
    probes = 1
    top = _trace_upper(A, C, Q, R, hi, budget)
    if top is None or top > target:
        return TraceTarget(target, None, hi, None, probes, False)
    best = top
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        tr = _trace_upper(A, C, Q, R, mid, budget)
        probes += 1
        if tr is not None and tr <= target:
            hi, best = mid, tr
        else:
            lo = mid
    return TraceTarget(target, hi, lo, best, probes, True)


__all__ = ["TraceTarget", "parse_trace_target", "smallest_arrival_for_trace"]
