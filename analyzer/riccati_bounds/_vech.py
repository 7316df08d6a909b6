"""Half-vectorization of symmetric matrices (``vech``), shared by the Riccati and ``P_hat_N`` code.

Working on ``vech`` keeps every iterate symmetric by construction: on full
``vec`` a float asymmetry is amplified like ``rho(A)^2`` per step and wrecks
long iterations (observed on Sinopoli et al. (2004)'s 3x3 example with Rohr, Marelli and Fu (2010)'s ``g_2``).
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


@lru_cache(maxsize=64)
def _congruence_layout(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The column gathers of :func:`congruence_matrix` (``k n + l``, ``l n + k``) and its diagonal columns."""
    iu, ju, _ = vech_layout(n)
    out = (iu * n + ju, ju * n + iu, np.flatnonzero(iu == ju))
    for a in out:
        a.setflags(write=False)
    return out


#: Up to this many states :func:`congruence_matrix` gathers from ``N x N`` index arrays kept per size
#: (``4 N^2`` integers); above, from the ``N x n^2`` products (the arrays would outgrow them).
SMALL_CONGRUENCE_N = 8


@lru_cache(maxsize=16)
def _small_congruence_layout(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Flat indices into ``M`` for :func:`congruence_matrix`, and its column factors (``1/2`` where ``k = l``).

    For ``p = (i, j)`` and ``q = (k, l)``: ``M_ik``, ``M_jl``, ``M_il``, ``M_jk`` as ``(N, N)`` index arrays.
    """
    iu, ju, _ = vech_layout(n)
    i, j = iu[:, None], ju[:, None]
    k, m = iu[None, :], ju[None, :]  # q = (k, m): the column
    out = (i * n + k, j * n + m, i * n + m, j * n + k, np.where(iu == ju, 0.5, 1.0))
    for a in out:
        a.setflags(write=False)
    return out


def congruence_matrix(M: np.ndarray) -> np.ndarray:
    r"""The matrix ``T`` with ``vech(M X M') = T vech(X)`` for symmetric ``X``.

    Entry by entry, with ``p = (i, j)`` and ``q = (k, l)`` running over the
    upper triangle (``i <= j``, ``k <= l``):

    .. math::

        T_{pq} = M_{ik} M_{jl} + M_{il} M_{jk} \ (k < l), \qquad T_{pq} = M_{ik} M_{jk} \ (k = l),

    since ``(M X M')_ij = sum_{k,l} M_ik X_kl M_jl`` and ``X_kl = X_lk``.
    Formed from the ``N x n^2`` products ``M_ik M_jl`` (``N = n(n+1)/2``) by two column
    gathers (up to :data:`SMALL_CONGRUENCE_N` states, from two ``N x N`` products gathered
    directly), with no ``n^2 x n^2`` Kronecker product: ``O(n^4)`` work instead of
    ``O(n^6)``, and the same floating-point sums entry by entry.

    Examples
    --------
    >>> import numpy as np
    >>> M, X = np.array([[1.0, 2.0], [0.0, 3.0]]), np.array([[2.0, 1.0], [1.0, 5.0]])
    >>> bool(np.allclose(congruence_matrix(M) @ vech(X), vech(M @ X @ M.T)))
    True
    """
    M = np.asarray(M, float)
    n = M.shape[0]
    if n <= SMALL_CONGRUENCE_N:  # the same products and sums as below, in fewer NumPy calls
        ik, jl, il, jk, halves = _small_congruence_layout(n)
        m = M.ravel()
        T: np.ndarray = m.take(ik) * m.take(jl)  # the products M_ik M_jl and M_il M_jk, summed in that order
        T += m.take(il) * m.take(jk)
        T *= halves  # k = l: both terms are M_ik M_jk, and halving 2ab is exact (elsewhere times 1, exact too)
        return T
    iu, ju, _ = vech_layout(n)
    upper, lower, diagonal = _congruence_layout(n)
    P, Q = M[iu], M[ju]  # rows M_i. and M_j. for every p = (i, j)
    W = (P[:, :, None] * Q[:, None, :]).reshape(len(iu), n * n)  # W[p, k n + l] = M_ik M_jl
    T = W[:, upper]
    T += W[:, lower]
    T[:, diagonal] *= 0.5
    return T


def vech(X: np.ndarray) -> np.ndarray:
    """The upper triangle of ``X``, row by row."""
    iu, ju, _ = vech_layout(X.shape[0])
    result: np.ndarray = X[iu, ju]
    return result


def unvech(h: np.ndarray, n: int) -> np.ndarray:
    """The symmetric ``n x n`` matrix whose upper triangle is ``h``."""
    iu, ju, _ = vech_layout(n)
    X = np.empty((n, n))
    X[iu, ju] = h
    X[ju, iu] = h
    return X
