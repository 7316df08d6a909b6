"""The dense reference solve of a Stein equation, for the tests of the GMRES routes."""

from __future__ import annotations

import numpy as np

from kfio.riccati_bounds._vech import congruence_matrix, unvech, vech


def dense(terms, W):
    """``X`` with ``X - sum_i w_i M_i X M_i' = W``, from the ``n(n+1)/2`` system on ``vech(X)``."""
    n = W.shape[0]
    L = np.eye(n * (n + 1) // 2)
    for w, M in terms:
        L -= w * congruence_matrix(M)
    return unvech(np.linalg.solve(L, vech(W)), n)
