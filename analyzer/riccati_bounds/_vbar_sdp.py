"""The ``V_bar`` SDP of Sinopoli et al. (2004) Theorem 6(b), compiled once per shape and re-solved.

The SDP is the cross-check of the MARE fixed point ``V_bar`` that ``kfio bounds`` prints
beside the iteration of :func:`kfio.riccati_bounds._riccati.solve_v_bar`.  Built afresh,
CVXPY spends most of a small request recompiling it.  Here it is written in CVXPY's DPP form
(each parameter multiplies a variable exactly once) through the Kronecker identities
``vec(A V B') = (B kron A) vec(V)``: the products ``A kron A``, ``C_S kron sqrt(pi(S)) A`` and
``C_S kron C_S`` are the parameters, and the compiled problem is cached per shape (``n`` and
the row counts of the patterns with ``pi(S) > 0``), so a later request of the same shape only
re-fills the solver's data.  The parameters hold ``n^4`` numbers, so this is done up to
:data:`COMPILED_MAX_N` states; above, compiling is a small part of the solve and the problem is
built afresh.

:func:`v_bar_sdp_fresh` builds the original problem every time (``A V A'`` with constant
matrices): the reference of the tests and of the benchmark.  The two formulations have the
same constraint in ``V`` entry by entry; Clarabel's answers differ by rounding in the
compiled data (relative 3e-11 on Sinopoli et al. (2004)'s 3x3 system at ``lambda = 0.4``).
"""

from __future__ import annotations

import threading
import warnings
from collections import OrderedDict
from dataclasses import dataclass
from typing import Sequence

import cvxpy as cp
import numpy as np

from ._riccati import ArrivalModel

SOLVER = cp.CLARABEL
#: Compiled problems kept (one per shape ``(n, row counts of the active patterns)``).
CACHE_SIZE = 8
#: Largest ``n`` solved by the compiled :class:`VBarSDP` (its parameters hold ``n^4`` numbers).
COMPILED_MAX_N = 12


@dataclass(frozen=True)
class SDPSolution:
    """``V_bar`` from :func:`v_bar_sdp`: the matrix (or ``None``), CVXPY status and solve time."""

    status: str
    matrix: np.ndarray | None
    solve_time: float | None


class VBarSDP:
    r"""The SDP of :func:`v_bar_sdp` with its data as CVXPY parameters, for one shape.

    With ``v = vec(V)`` (column-major),

    .. math::

        \operatorname{vec}(A V A') = (A \otimes A) v,\quad
        \operatorname{vec}(\sqrt{\pi(S)} A V C_S') = (C_S \otimes \sqrt{\pi(S)} A) v,\quad
        \operatorname{vec}(C_S V C_S') = (C_S \otimes C_S) v,

    and the three Kronecker products, ``Q`` and ``R_SS`` are the parameters.

    Parameters
    ----------
    n:
        Number of states.
    rows:
        Number of rows of ``C_S`` for each pattern with ``pi(S) > 0`` (in mask order).
    """

    def __init__(self, n: int, rows: Sequence[int]) -> None:
        self.n, self.rows = n, tuple(rows)
        self.V = cp.Variable((n, n), symmetric=True)
        v = cp.vec(self.V, order="F")
        self._KA = cp.Parameter((n * n, n * n))
        self._Q = cp.Parameter((n, n))
        self._KAC = [cp.Parameter((n * p, n * n)) for p in self.rows]
        self._KCC = [cp.Parameter((p * p, n * n)) for p in self.rows]
        self._R = [cp.Parameter((p, p)) for p in self.rows]

        def mat(K: cp.Parameter, a: int, b: int) -> cp.Expression:
            return cp.reshape(K @ v, (a, b), order="F")

        top = [mat(self._KA, n, n) + self._Q - self.V] + [mat(K, n, p) for K, p in zip(self._KAC, self.rows)]
        blocks = [top]
        for i, p in enumerate(self.rows):
            row = [top[i + 1].T]
            for j, q in enumerate(self.rows):
                row.append(mat(self._KCC[i], p, p) + self._R[i] if i == j else np.zeros((p, q)))
            blocks.append(row)
        gamma = cp.bmat(blocks)
        self.problem = cp.Problem(cp.Maximize(cp.trace(self.V)), [0.5 * (gamma + gamma.T) >> 0, self.V >> 0])
        self.lock = threading.Lock()

    def is_dpp(self) -> bool:
        return bool(self.problem.is_dcp(dpp=True))  # type: ignore[call-arg]  # CVXPY's stub lacks dpp

    def solve(self, model: ArrivalModel) -> SDPSolution:
        """Fill the parameters from ``model`` and solve (callers hold :attr:`lock`)."""
        A = model.A
        self._KA.value = np.kron(A, A)
        self._Q.value = model.Q
        for (w, C, R), KAC, KCC, Rp in zip(model.active(), self._KAC, self._KCC, self._R):
            KAC.value = np.kron(C, np.sqrt(w) * A)
            KCC.value = np.kron(C, C)
            Rp.value = R
        # warm_start=False: a new Clarabel instance every time.  CVXPY's default updates the previous
        # instance in place, whose answer differs from a first solve's in the last bits, so a
        # request's answer would depend on what the process solved before.
        return _solve(self.problem, self.V, warm_start=False)


def _solve(problem: cp.Problem, V: cp.Variable, **options: object) -> SDPSolution:
    try:
        with warnings.catch_warnings():  # an inaccurate answer shows in the status and in the cross-check
            warnings.simplefilter("ignore", UserWarning)
            problem.solve(solver=SOLVER, **options)  # type: ignore[arg-type]
    except cp.SolverError:
        return SDPSolution("solver_error", None, None)
    status = str(problem.status)
    stats = problem.solver_stats
    if status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) or V.value is None:
        return SDPSolution(status, None, stats.solve_time if stats else None)
    return SDPSolution(status, 0.5 * (V.value + V.value.T), stats.solve_time if stats else None)


_CACHE: OrderedDict[tuple[int, tuple[int, ...]], VBarSDP] = OrderedDict()
_CACHE_LOCK = threading.Lock()


def _compiled(n: int, rows: tuple[int, ...]) -> VBarSDP:
    key = (n, rows)
    with _CACHE_LOCK:
        sdp = _CACHE.get(key)
        if sdp is None:
            sdp = _CACHE[key] = VBarSDP(n, rows)
            while len(_CACHE) > CACHE_SIZE:
                _CACHE.popitem(last=False)
        _CACHE.move_to_end(key)
        return sdp


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
    unbounded).  Solved as :class:`VBarSDP`, compiled once per shape, up to
    :data:`COMPILED_MAX_N` states.
    """
    if model.n > COMPILED_MAX_N:
        return v_bar_sdp_fresh(model)
    sdp = _compiled(model.n, tuple(C.shape[0] for _, C, _ in model.active()))
    with sdp.lock:
        return sdp.solve(model)


def v_bar_sdp_fresh(model: ArrivalModel) -> SDPSolution:
    """:func:`v_bar_sdp` with a new CVXPY problem built from constant matrices (no parameters, no cache).

    The formulation before the compiled one; kept as the reference of the tests and of
    ``bench/bench_bounds_speed.py``.
    """
    A, Q = model.A, model.Q
    n = model.n
    V = cp.Variable((n, n), symmetric=True)
    active = model.active()
    top = [A @ V @ A.T + Q - V] + [np.sqrt(w) * A @ V @ C.T for w, C, _ in active]
    rows = [top]
    for i, (w, C, R) in enumerate(active):
        row = [np.sqrt(w) * C @ V @ A.T]
        for j, (_, Cj, _) in enumerate(active):
            row.append(C @ V @ C.T + R if i == j else np.zeros((C.shape[0], Cj.shape[0])))
        rows.append(row)
    gamma = cp.bmat(rows)
    problem = cp.Problem(cp.Maximize(cp.trace(V)), [0.5 * (gamma + gamma.T) >> 0, V >> 0])
    return _solve(problem, V, warm_start=False)
