"""The filtered covariance ``P(t|t)`` from the predictor ``P(t|t-1)`` and the arrivals at ``t``.

The papers (Sinopoli et al. 2004; Rohr, Marelli and Fu 2014) bound the
one-step predictor ``P(t|t-1)``, written ``P_t``.  MATLAB's ``kalman`` and
python-control also report the filtered covariance.  Given ``P = P_t`` and the
set ``S`` of packets that arrived at ``t``, the measurement update is

.. math::

    P(t|t) = P - P C_S' (C_S P C_S' + R_{SS})^{-1} C_S P = (P^{-1} + C_S' R_{SS}^{-1} C_S)^{-1},

and ``P(t|t) = P`` when nothing arrived.  The exact enumeration
(:mod:`kfio.simulation._finite_horizon`) applies this function; the Monte
Carlo simulation gets the same update in square-root form, ``P - V'V``, from
the Riccati kernel's own pass (:meth:`kfio.simulation._kernel.RiccatiStep.update`,
:class:`kfio.simulation._packed.PackedRiccatiStep`), with the same arrival
draws, so the predictor output (and the random stream) is unchanged.
"""

from __future__ import annotations

import numpy as np


def filtered_covariance(P: np.ndarray, C: np.ndarray, R: np.ndarray, rowmask: np.ndarray | None = None) -> np.ndarray:
    """``P - P C_S' (C_S P C_S' + R_SS)^{-1} C_S P`` for a batch ``P`` of shape ``(M, n, n)``.

    Parameters
    ----------
    P:
        Predictor covariances ``P(t|t-1)``.
    C, R:
        All measurement rows ``(p, n)`` and their noise covariance ``(p, p)``.
    rowmask:
        ``(M, p)`` 0/1: the rows that arrived in each trajectory (``None``: all).
        Lost rows are masked out (their row of ``C P`` zeroed, their block of
        the innovation covariance replaced by the identity), so they contribute
        nothing and an empty arrival set returns ``P``.

    Examples
    --------
    Scalar ``P = 4``, ``C = R = 1``: ``4 - 16/5 = 0.8``; lost: ``4``.

    >>> import numpy as np
    >>> from kfio.simulation._filtered import filtered_covariance
    >>> P = np.full((2, 1, 1), 4.0)
    >>> out = filtered_covariance(P, np.eye(1), np.eye(1), np.array([[1.0], [0.0]]))
    >>> np.round(out[:, 0, 0], 12).tolist()
    [0.8, 4.0]
    """
    CP = np.matmul(C, P)
    if rowmask is not None:
        CP = CP * rowmask[:, :, None]
    S = np.matmul(CP, C.T) + R
    if rowmask is not None:
        outer = rowmask[:, :, None] * rowmask[:, None, :]
        S = S * outer + np.eye(C.shape[0]) * (1.0 - rowmask)[:, :, None]
    if C.shape[0] == 1:
        corr = CP[:, 0, :, None] * CP[:, 0, None, :] / S[:, 0, 0, None, None]
    else:
        corr = np.matmul(np.swapaxes(CP, 1, 2), np.linalg.solve(S, CP))
        corr = 0.5 * (corr + np.swapaxes(corr, 1, 2))
    result: np.ndarray = P - corr
    return result


__all__ = ["filtered_covariance"]
