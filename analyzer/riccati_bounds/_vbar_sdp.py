"""The ``V_bar`` SDP of Sinopoli et al. (2004) Theorem 6(b), handed to Clarabel without CVXPY.

The SDP is the cross-check of the MARE fixed point ``V_bar`` that ``kfio bounds`` prints
beside the iteration of :func:`kfio.riccati_bounds._riccati.solve_v_bar`.  Built afresh,
CVXPY spends most of a small request compiling it; compiled once per shape with parameters, it
still spent about 4 ms per request filling the solver's data.  Up to :data:`COMPILED_MAX_N`
states the conic program is now written out directly (:mod:`kfio.riccati_bounds._vbar_conic`)
and solved by Clarabel, the solver CVXPY called, with CVXPY's names for its statuses.  Above,
the CVXPY problem is built afresh (compiling is then a small part of the solve).

:func:`v_bar_sdp_fresh` builds the CVXPY problem every time (``A V A'`` with constant
matrices): the reference of the tests and of the benchmark.  The two programs have the same
constraints in ``V`` entry by entry, in another order and with other rounding of the data, so
Clarabel's answers differ in the last digits it resolves (relative 1.5e-10 on Sinopoli et al.
(2004)'s 3x3 system at ``lambda = 0.4``, far inside the 1e-7 the cross-check allows).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import cvxpy as cp
import numpy as np

from ._riccati import ArrivalModel
from ._vbar_conic import solve_conic

SOLVER = cp.CLARABEL
#: Largest ``n`` whose SDP is built by hand (:mod:`kfio.riccati_bounds._vbar_conic`; the name is
#: from when CVXPY compiled it once per shape); ``options.bounds.sdp_cross_check = "auto"``
#: solves it up to here.
COMPILED_MAX_N = 12


@dataclass(frozen=True)
class SDPSolution:
    """``V_bar`` from :func:`v_bar_sdp`: the matrix (or ``None``), CVXPY status and solve time."""

    status: str
    matrix: np.ndarray | None
    solve_time: float | None


def _solve(problem: cp.Problem, V: cp.Variable, **options: object) -> SDPSolution:
    try:
        with warnings.catch_warnings():  # an inaccurate answer shows in the status and in the cross-check
            warnings.simplefilter("ignore", UserWarning)
            problem.solve(solver=SOLVER, **options)
    except cp.SolverError:
        return SDPSolution("solver_error", None, None)
    status = str(problem.status)
    stats = problem.solver_stats
    if status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) or V.value is None:
        return SDPSolution(status, None, stats.solve_time if stats else None)
    return SDPSolution(status, 0.5 * (V.value + V.value.T), stats.solve_time if stats else None)


def v_bar_sdp(model: ArrivalModel) -> SDPSolution:
    r"""``V_bar`` as the SDP of Sinopoli et al. (2004) Theorem 6(b), generalized to ``m`` packets (Liu and Goldsmith (2004), eq. 21).

    .. math::

        \max \operatorname{tr} V \ \text{s.t.}\
        \begin{bmatrix}
            A V A' + Q - V & \sqrt{\pi(S_1)} A V C_{S_1}' & \cdots \\
            \ast & C_{S_1} V C_{S_1}' + R_{S_1 S_1} & 0 \\
            \vdots & 0 & \ddots
        \end{bmatrix} \succeq 0,\quad V \succeq 0.

    The Schur complement of the constraint is ``g(V) - V >= 0``; ``V_bar`` is
    the greatest element of that set (Sinopoli et al. (2004), proof of Theorem 6), so it
    maximizes the trace.  Sinopoli et al. (2004) prints the top-left block without ``Q``:
    a typo (without ``Q`` the SDP is homogeneous and its answer is 0 or
    unbounded).  Up to :data:`COMPILED_MAX_N` states the conic program is built by hand
    (:func:`kfio.riccati_bounds._vbar_conic.solve_conic`); above, by CVXPY
    (:func:`v_bar_sdp_fresh`).
    """
    if model.n > COMPILED_MAX_N:
        return v_bar_sdp_fresh(model)
    status, V, solve_time = solve_conic(model)
    return SDPSolution(status, V, solve_time)


def lmi_blocks(model: ArrivalModel, V: np.ndarray | cp.Expression) -> list[list[Any]]:
    """The blocks of the constraint matrix of :func:`v_bar_sdp` at ``V``, row by row.

    ``[[A V A' + Q - V, sqrt(pi_1) A V C_1', ...], [sqrt(pi_1) C_1 V A', C_1 V C_1' + R_1, 0, ...], ...]``
    (Sinopoli et al. (2004) Theorem 6(b), one block row per packet as in Liu and Goldsmith
    (2004), eq. 21).  ``V`` may be a NumPy array (``np.block`` of the result is the matrix) or a
    CVXPY variable (``cp.bmat``).
    """
    A, Q = model.A, model.Q
    active = model.active()
    rows = [[A @ V @ A.T + Q - V] + [np.sqrt(w) * A @ V @ C.T for w, C, _ in active]]
    for i, (w, C, R) in enumerate(active):
        row = [np.sqrt(w) * C @ V @ A.T]
        for j, (_, Cj, _) in enumerate(active):
            row.append(C @ V @ C.T + R if i == j else np.zeros((C.shape[0], Cj.shape[0])))
        rows.append(row)
    return rows


def v_bar_sdp_fresh(model: ArrivalModel) -> SDPSolution:
    """:func:`v_bar_sdp` with a new CVXPY problem built from constant matrices.

    The route above :data:`COMPILED_MAX_N` states, and the reference of the tests.
    """
    V = cp.Variable((model.n, model.n), symmetric=True)
    gamma = cp.bmat(lmi_blocks(model, V))
    problem = cp.Problem(cp.Maximize(cp.trace(V)), [0.5 * (gamma + gamma.T) >> 0, V >> 0])
    return _solve(problem, V, warm_start=False)
