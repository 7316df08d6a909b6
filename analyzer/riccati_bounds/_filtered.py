"""Filtered counterparts ``P(t|t)`` of the predictor bounds ``S_bar``, ``V_bar`` and ``P_hat_N``.

The bounds of Sinopoli et al. (2004, Theorems 3-4) and of Rohr, Marelli and
Fu (2010) are on the one-step predictor ``P_t = P(t|t-1)``.  The filtered
covariance is ``P(t|t) = F_{S_t}(P_t)`` with, for an arrival set ``S``,

.. math::

    F_S(P) = P - P C_S' (C_S P C_S' + R_{SS})^{-1} C_S P = (P^{-1} + C_S' R_{SS}^{-1} C_S)^{-1},
    \\qquad F_\\emptyset(P) = P.

For i.i.d. arrivals (Bernoulli, one or several independent packets) the set
``S_t`` is independent of ``P_t``, which depends on earlier arrivals only, so

.. math::

    E[P(t|t)] = \\sum_S \\pi(S)\\, E[F_S(P_t)].

**Upper bound.**  ``F_S`` is monotone and matrix-concave in ``P`` (it is
the inverse of ``P^{-1} + C_S' R^{-1} C_S``; equivalently the Schur complement
of a block that is linear in ``P``; Sinopoli et al. 2004, Lemma 1, use the same
facts for the MARE).  Jensen's inequality for a concave map gives
``E[F_S(P_t)] <= F_S(E[P_t])``, and monotonicity with ``E[P_t] <= V_t``
(Sinopoli et al. 2004, Theorem 4, ``V_t -> V_bar``) gives

.. math::

    \\limsup_t E[P(t|t)] \\le \\bar V_f := \\sum_S \\pi(S) F_S(\\bar V)
    = \\bar V - \\sum_{S \\ne \\emptyset} \\pi(S)\\, \\bar V C_S'(C_S \\bar V C_S' + R_{SS})^{-1} C_S \\bar V,

and with ``P_0 <= V_bar`` (e.g. ``P_0 = Q``) the bound holds at every ``t``
(``V_t`` increases to ``V_bar``).  The same argument applies verbatim to any
upper bound of ``lim E[P_t]``, such as ``P_hat_N``.

**Lower bound.**  ``F_S(P) >= 0``, so ``E[P(t|t)] >= pi(empty) E[P_t]`` and
``liminf_t E[P(t|t)] >= pi(empty) S_bar``.  It is weak (it ignores what an
arrival leaves), but it is a bound.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._reporting import ReportPart
from ._riccati import ArrivalModel


def filtered_mean(model: ArrivalModel, P: np.ndarray) -> np.ndarray:
    """``sum_S pi(S) F_S(P)``: the filtered covariance averaged over one step's arrival set.

    Examples
    --------
    Scalar ``P = 4``, ``C = R = 1``, ``lambda = 1/2``: ``(4 + 0.8) / 2 = 2.4``.

    >>> import numpy as np
    >>> from kfio.riccati_bounds._riccati import ArrivalModel
    >>> from kfio.riccati_bounds._filtered import filtered_mean
    >>> m = ArrivalModel(np.eye(1), np.eye(1), (np.eye(1),), (np.eye(1),), (0.5, 0.5))
    >>> round(float(filtered_mean(m, np.full((1, 1), 4.0))[0, 0]), 12)
    2.4
    """
    out = np.asarray(P, dtype=float).copy()
    for w, C, R in model.active():
        CP = C @ P
        out -= w * CP.T @ np.linalg.solve(C @ P @ C.T + R, CP)
    result: np.ndarray = 0.5 * (out + out.T)
    return result


@dataclass(frozen=True)
class FilteredBounds(ReportPart):
    """``pi(empty) S_bar <= liminf E[P(t|t)]`` and ``limsup E[P(t|t)] <= sum_S pi(S) F_S(V_bar)``."""

    lower: np.ndarray | None
    upper: np.ndarray | None


def filtered_bounds(model: ArrivalModel, s_bar: np.ndarray | None, v_bar: np.ndarray | None) -> FilteredBounds:
    """The filtered bounds of the module docstring from the predictor bounds."""
    lower = None if s_bar is None else model.loss_probability * s_bar
    upper = None if v_bar is None else filtered_mean(model, v_bar)
    return FilteredBounds(lower, upper)


__all__ = ["FilteredBounds", "filtered_bounds", "filtered_mean"]
