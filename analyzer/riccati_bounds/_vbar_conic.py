"""The ``V_bar`` SDP of Sinopoli et al. (2004) Theorem 6(b) as Clarabel's conic program, built by hand.

Clarabel (the interior-point solver CVXPY calls) solves ``min q'x  s.t.  A x + s = b,  s in K``.  Here ``x`` is
the upper triangle of the symmetric ``V``, column by column (``x_k = V_ij``, ``i <= j``), so
``V = sum_k x_k E_k`` with ``E_k`` the symmetric unit matrix of entry ``(i, j)``.  Both constraints
of :func:`kfio.riccati_bounds._vbar_sdp.v_bar_sdp` are affine in ``V``:

    Gamma(V) = Gamma_0 + sum_k x_k Gamma(E_k) - Gamma_0 >= 0,      V >= 0,

with ``Gamma_0 = diag(Q, R_S1, R_S2, ...)`` the constant part.  Clarabel's positive semidefinite
cone in triangle form takes ``s = svec(M)``: the upper triangle column by column, off-diagonal
entries times ``sqrt 2`` (so that ``svec(M)'svec(N) = tr(MN)``).  Hence ``b = svec(Gamma_0)`` and
the column ``k`` of ``A`` is ``-svec(Gamma(E_k) - Gamma_0)``, one batched product per block
for all ``k`` at once; the objective ``max tr V`` is ``q = -1`` on the diagonal entries.  This is
the program CVXPY compiles from the same problem, up to the order of the rows and the rounding
of the data, without its compilation (about 4 ms of a 3x3 request).
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import clarabel
import numpy as np
import scipy.sparse as sp

from ._riccati import ArrivalModel

#: CVXPY's names for Clarabel's statuses (``cvxpy.CLARABEL.STATUS_MAP``), so that a report says
#: what it said when the problem went through CVXPY.
STATUS = {
    "Solved": "optimal",
    "PrimalInfeasible": "infeasible",
    "DualInfeasible": "unbounded",
    "AlmostSolved": "optimal_inaccurate",
    "AlmostPrimalInfeasible": "infeasible_inaccurate",
    "AlmostDualInfeasible": "unbounded_inaccurate",
    "MaxIterations": "user_limit",
    "MaxTime": "user_limit",
    "NumericalError": "solver_error",
    "InsufficientProgress": "solver_error",
    "Unsolved": "solver_error",
}
#: Statuses with an answer to report (the rest report ``None``).
ANSWERED = ("optimal", "optimal_inaccurate")


@lru_cache(maxsize=64)
def _triangle(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(i, j, scale)`` of ``svec`` for ``n x n``: upper triangle column by column, ``sqrt 2`` off the diagonal."""
    j = np.repeat(np.arange(n), np.arange(1, n + 1))  # columns 0, 1, 1, 2, 2, 2, ...
    i = np.concatenate([np.arange(c + 1) for c in range(n)]) if n else np.zeros(0, int)
    scale = np.where(i == j, 1.0, np.sqrt(2.0))
    for a in (i, j, scale):
        a.setflags(write=False)
    return i, j, scale


def conic_program(model: ArrivalModel) -> tuple[np.ndarray, sp.csc_array, np.ndarray, list[Any]]:
    """``(q, A, b, cones)`` of the ``V_bar`` SDP for Clarabel (see the module docstring)."""
    A, Q, n = model.A, model.Q, model.n
    active = model.active()
    rows = [C.shape[0] for _, C, _ in active]
    D = n + sum(rows)
    i, j, _ = _triangle(n)
    m = len(i)
    E = np.zeros((m, n, n))
    k = np.arange(m)
    E[k, i, j] = 1.0
    E[k, j, i] = 1.0
    G = np.zeros((m, D, D))
    G[:, :n, :n] = A @ E @ A.T - E
    G0 = np.zeros((D, D))
    G0[:n, :n] = Q
    at = n
    for (w, C, R), p in zip(active, rows):
        G[:, :n, at : at + p] = np.sqrt(w) * A @ E @ C.T
        G[:, at : at + p, at : at + p] = C @ E @ C.T
        G0[at : at + p, at : at + p] = R
        at += p
    gi, gj, gs = _triangle(D)
    vi, vj, vs = _triangle(n)
    dense = np.vstack([-(G[:, gi, gj] * gs).T, -np.diag(vs)])
    b = np.concatenate([G0[gi, gj] * gs, np.zeros(m)])
    q = np.where(i == j, -1.0, 0.0)
    return q, sp.csc_array(dense), b, [clarabel.PSDTriangleConeT(D), clarabel.PSDTriangleConeT(n)]


def solve_conic(model: ArrivalModel) -> tuple[str, np.ndarray | None, float | None]:
    """``(status, V, solve_time)`` of the ``V_bar`` SDP by Clarabel on :func:`conic_program`.

    The status is CVXPY's name for Clarabel's (:data:`STATUS`); ``V`` is ``None`` unless the
    status is in :data:`ANSWERED`.  ``"solver_error"`` has no solve time, as through CVXPY
    (which raises there).
    """
    q, A, b, cones = conic_program(model)
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    m = q.size
    solution = clarabel.DefaultSolver(sp.csc_array((m, m)), q, A, b, cones, settings).solve()
    status = STATUS.get(str(solution.status), "solver_error")
    if status == "solver_error":
        return status, None, None
    if status not in ANSWERED:
        return status, None, solution.solve_time
    n = model.n
    i, j, _ = _triangle(n)
    V = np.zeros((n, n))
    V[i, j] = solution.x
    V[j, i] = solution.x
    return status, V, solution.solve_time
