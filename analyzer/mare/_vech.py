"""Half-vectorization of symmetric matrices (``vech``), shared by the Riccati and ``P_hat_N`` code.

Working on ``vech`` keeps every iterate symmetric by construction: on full
``vec`` a float asymmetry is amplified like ``rho(A)^2`` per step and wrecks
long iterations (observed on seed 004's 3x3 example with seed 002's ``g_2``).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np


@lru_cache(maxsize=64)
def vech_layout(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(iu, ju, dup)``: ``vech(X) = X[iu, ju]`` and ``vec(X) = dup @ vech(X)`` for symmetric ``X``."""
    iu, ju = np.triu_indices(n)
    dup = np.zeros((n * n, len(iu)))
    dup[iu * n + ju, np.arange(len(iu))] = 1.0
    dup[ju * n + iu, np.arange(len(iu))] = 1.0
    for a in (iu, ju, dup):
        a.setflags(write=False)
    return iu, ju, dup


def congruence_matrix(M: np.ndarray) -> np.ndarray:
    """The matrix ``T`` with ``vech(M X M') = T vech(X)`` for symmetric ``X``.

    Examples
    --------
    >>> import numpy as np
    >>> M, X = np.array([[1.0, 2.0], [0.0, 3.0]]), np.array([[2.0, 1.0], [1.0, 5.0]])
    >>> bool(np.allclose(congruence_matrix(M) @ vech(X), vech(M @ X @ M.T)))
    True
    """
    n = M.shape[0]
    iu, ju, dup = vech_layout(n)
    return (np.kron(M, M) @ dup)[iu * n + ju]


def vech(X: np.ndarray) -> np.ndarray:
    """The upper triangle of ``X``, row by row."""
    iu, ju, _ = vech_layout(X.shape[0])
    return X[iu, ju]


def unvech(h: np.ndarray, n: int) -> np.ndarray:
    """The symmetric ``n x n`` matrix whose upper triangle is ``h``."""
    iu, ju, _ = vech_layout(n)
    X = np.empty((n, n))
    X[iu, ju] = h
    X[ju, iu] = h
    return X
