"""``trace(S_bar)`` and ``trace(V_bar)`` along a range of arrival probabilities.

The phase transition of Sinopoli et al. (2004), Figs. 1-3: for one packet over
a Bernoulli channel, ``S_bar <= lim E[P_t] <= V_bar`` (their Theorem 4), with
``S_bar`` existing above ``1 - 1/rho(A)^2`` and ``V_bar`` where the MARE
iteration converges.  The HTTP service draws this sweep; computing it here
keeps the plotting code free of mathematics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from .._budget import Budget
from ..errors import AnalyzerError
from ._riccati import s_bar, v_bar


@dataclass(frozen=True)
class BoundTraces:
    """Traces of the two bounds on ``lim E[P_t]`` at each arrival probability.

    Attributes
    ----------
    lambdas:
        The arrival probabilities, as given.
    s_bar:
        ``trace(S_bar)``; NaN where ``S_bar`` does not exist.
    v_bar:
        ``trace(V_bar)``; NaN where ``V_bar`` does not exist or was not
        evaluated (below ``v_bar_from``).
    """

    lambdas: np.ndarray
    s_bar: np.ndarray
    v_bar: np.ndarray


def _trace_or_nan(fn: Callable[..., Any], *args: Any) -> float:
    """``trace(fn(*args))``; NaN where the bound does not exist (``None``, non-finite, or refused)."""
    try:
        value = fn(*args)
    except (AnalyzerError, ArithmeticError, np.linalg.LinAlgError):
        return math.nan
    if value is None:
        return math.nan
    tr = float(np.trace(np.asarray(value, dtype=float)))
    return tr if math.isfinite(tr) and tr >= 0 else math.nan


def bound_traces(
    A: np.ndarray,
    C: np.ndarray,
    Q: np.ndarray,
    R: np.ndarray,
    lambdas: Sequence[float] | np.ndarray,
    *,
    v_bar_from: float | None = None,
    budget: Budget | None = None,
) -> BoundTraces:
    r"""``trace(S_bar)`` and ``trace(V_bar)`` for one packet at each arrival probability.

    ``S_bar`` solves :math:`S = (1 - \lambda) A S A' + Q` and ``V_bar`` is the
    fixed point of the MARE :math:`g_\lambda(X) = AXA' + Q - \lambda AXC'(CXC' + R)^{-1}CXA'`;
    between them lies the limit of the expected error covariance
    (Sinopoli et al., 2004, Theorems 3-6).

    Parameters
    ----------
    A, C, Q, R:
        The plant, as float arrays.
    lambdas:
        Arrival probabilities in ``[0, 1]``.
    v_bar_from:
        Evaluate ``V_bar`` only at ``lambda >= v_bar_from`` (the LMI upper
        bound, above which the MARE iteration is known to converge; just
        below it divergence is slow to detect).  ``None``: everywhere.
    budget:
        Work budget, ticked twice per point.

    Returns
    -------
    BoundTraces

    Examples
    --------
    The scalar system of Sinopoli et al. (2004), Fig. 1, whose critical
    probability is ``1 - 1/1.25^2 = 0.36``:

    >>> import numpy as np
    >>> A, C, Q, R = np.array([[-1.25]]), np.array([[1.0]]), np.array([[1.0]]), np.array([[2.5]])
    >>> t = bound_traces(A, C, Q, R, [0.3, 0.6])
    >>> bool(np.isnan(t.s_bar[0])), round(float(t.s_bar[1]), 6)  # 1 / (1 - 0.4 * 1.5625)
    (True, 2.666667)
    >>> bool(t.s_bar[1] <= t.v_bar[1])
    True
    """
    lams = np.asarray(lambdas, dtype=float)
    s_tr = np.full(lams.shape, math.nan)
    v_tr = np.full(lams.shape, math.nan)
    for i, lam in enumerate(lams):
        if budget is not None:
            budget.tick("S_bar/V_bar sweep", 2)
        s_tr[i] = _trace_or_nan(s_bar, A, Q, 1.0 - lam)
        if v_bar_from is None or lam >= v_bar_from:
            v_tr[i] = _trace_or_nan(v_bar, A, C, Q, R, lam)
    return BoundTraces(lams, s_tr, v_tr)


__all__ = ["BoundTraces", "bound_traces"]
