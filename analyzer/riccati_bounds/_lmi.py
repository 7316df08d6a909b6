"""CVXPY problems for the bounds of docs/theory.md: the stability LMI and the ``V_bar`` SDP.

* :class:`StabilityLMI` is Sinopoli et al. (2004)'s Theorem 5(c) LMI ``Psi_lambda(Y, Z) > 0,
  0 < Y <= I`` and its ``m``-packet generalization (Liu and Goldsmith (2004), eq. 20 is
  ``m = 2``), built once with CVXPY parameters and re-solved at every
  bisection step (DPP: each parameter multiplies a variable exactly once).
* the ``V_bar`` SDP of Theorem 6(b) is :mod:`kfio.riccati_bounds._vbar_sdp`.

Solver answers are hypotheses: :mod:`kfio.riccati_bounds._certificate` re-checks
them.  The solver is Clarabel (interior point; CVXPY's ``warm_start`` only
lets it update its data in place, it does not seed the iterates).
"""

from __future__ import annotations

import threading
import warnings
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any, Sequence

import cvxpy as cp
import numpy as np
import scipy.linalg

SOLVER = cp.CLARABEL
#: Clarabel options for the stability LMI: its defaults (1e-8).  Looser ones (1e-7) save a fifth
#: of the iterations but stop producing certifiable gains earlier near the threshold (on a random
#: n = 10 system lambda_upper rose by 2e-5); tighter ones (1e-9) gain nothing measurable.
LMI_SOLVER_OPTIONS: dict[str, float] = {}


def balancing_scaling(A: np.ndarray) -> np.ndarray:
    """Diagonal ``d`` (powers of 2) with ``D^-1 A D`` balanced, ``D = diag(d)`` (LAPACK ``gebal``).

    Balancing reduces the spread of the entries of ``A`` before it enters the
    LMI; the state change ``x -> D^-1 x`` leaves feasibility unchanged.
    """
    _, (scale, _) = scipy.linalg.matrix_balance(np.asarray(A, float), permute=False, separate=True)
    return np.asarray(scale, float)


@dataclass(frozen=True)
class LMISolution:
    """What the solver returned for :class:`StabilityLMI`.

    Attributes
    ----------
    status:
        CVXPY status string.
    margin:
        The optimal ``t`` in ``Psi(Y, Z) >= t I``: the solver's own margin,
        not a proof of anything.
    Y:
        ``n x n`` or ``None``.
    Z:
        One ``n x p_S`` matrix per non-empty arrival pattern (mask order), or ``None``.
    """

    status: str
    margin: float | None
    Y: np.ndarray | None
    Z: tuple[np.ndarray, ...] | None

    def gains(self) -> tuple[np.ndarray, ...] | None:
        """``K_S = Y^-1 Z_S``: then ``Y(A + K_S C_S) = Y A + Z_S C_S`` (Sinopoli et al. (2004), proof of Theorem 5)."""
        if self.Y is None or self.Z is None:
            return None
        try:
            return tuple(np.linalg.solve(self.Y, Z) for Z in self.Z)
        except np.linalg.LinAlgError:
            return None


class StabilityLMI:
    r"""The LMI whose feasibility defines ``lambda_upper`` (Sinopoli et al. (2004), Theorem 5(c); Liu and Goldsmith (2004), eq. 20).

    For ``m`` packets with pattern probabilities ``pi(S)``:

    .. math::

        \Psi = \begin{bmatrix}
            Y & \sqrt{\pi(S_1)}(Y A + Z_{S_1} C_{S_1}) & \cdots & \sqrt{\pi(\emptyset)}\, Y A \\
            \ast & Y & & 0 \\
            \vdots & & \ddots & \\
            \ast & 0 & & Y
        \end{bmatrix} \succ 0, \qquad 0 \prec Y \preceq I,

    one block per non-empty pattern ``S`` and one for the empty pattern.  By
    Schur complements and the change of variables ``X = Y^-1``,
    ``K_S = X Z_S``, it is equivalent to ``X > L_K(X)`` with ``L_K`` of
    :func:`kfio.riccati_bounds._riccati.closed_loop_operator`.  We maximize ``t`` subject
    to ``Psi >= t I`` so that the answer is as far inside the cone as the
    normalization ``Y <= I`` allows.

    The products ``sqrt(pi(S)) A`` and ``sqrt(pi(S)) C_S`` are the parameters
    (in whatever coordinates the caller works), so the problem is DPP and
    re-solving it only re-fills the solver's data.  The compiled problem is shared by every
    instance of the same shape (:class:`_CompiledLMI`); each instance keeps its own solver.

    Parameters
    ----------
    n:
        Number of states.
    pattern_rows:
        Number of rows of ``C_S`` for each non-empty pattern, in mask order.
    """

    def __init__(self, n: int, pattern_rows: Sequence[int]) -> None:
        self.n = n
        self.pattern_rows = tuple(pattern_rows)
        self._compiled = _compiled(n, self.pattern_rows)
        self.size = self._compiled.size
        # This instance's own Clarabel instance, kept between its solves (``warm_start``) and
        # never seen by another instance of the same shape: the answers are those of a problem
        # of its own, whatever else the process solved before or in between.
        self._solver_cache: dict[Any, Any] = {}

    def is_dpp(self) -> bool:
        return bool(self._compiled.problem.is_dcp(dpp=True))  # type: ignore[call-arg]  # CVXPY's stub lacks dpp

    def solve(self, A: np.ndarray, C_S: Sequence[np.ndarray], weights: Sequence[float]) -> LMISolution:
        """Solve at pattern probabilities ``weights`` (``weights[0] = pi(empty)``).

        ``A`` and ``C_S`` are in the caller's working coordinates; the
        returned ``Y``, ``Z`` are in the same coordinates.
        """
        c = self._compiled
        with c.lock:  # the parameters, the solve and the values read back belong to one caller
            for MA, MC, w, C in zip(c.MA, c.MC, weights[1:], C_S):
                s = np.sqrt(max(0.0, float(w)))
                MA.value = s * A
                MC.value = s * C
            c.M0.value = np.sqrt(max(0.0, float(weights[0]))) * A
            c.problem._solver_cache = self._solver_cache
            try:
                with warnings.catch_warnings():  # "may be inaccurate": the status says so and the answer is re-checked
                    warnings.simplefilter("ignore", UserWarning)
                    c.problem.solve(solver=SOLVER, warm_start=True, **LMI_SOLVER_OPTIONS)
            except cp.SolverError:
                return LMISolution("solver_error", None, None, None)
            finally:
                c.problem._solver_cache = {}  # the Clarabel instance lives as long as this StabilityLMI only
            status = str(c.problem.status)
            if c.Y.value is None or c.t.value is None:
                return LMISolution(status, None, None, None)
            Y = 0.5 * (c.Y.value + c.Y.value.T)
            return LMISolution(status, float(c.t.value), Y, tuple(np.array(Z.value) for Z in c.Z))


class _CompiledLMI:
    """The CVXPY problem of :class:`StabilityLMI` for one shape, compiled on its first solve.

    CVXPY keeps the compiled program (its parameters' map to the solver's data) in the problem,
    so one problem per shape serves every request; compiling it was about 20 ms of a 2x2
    ``bounds`` request.  The Clarabel instance that ``warm_start`` updates stays per
    :class:`StabilityLMI` (its ``_solver_cache``), so sharing the compiled problem changes no
    answer.
    """

    def __init__(self, n: int, pattern_rows: tuple[int, ...]) -> None:
        self.Y = Y = cp.Variable((n, n), symmetric=True)
        self.t = cp.Variable()
        self.Z = [cp.Variable((n, p)) for p in pattern_rows]
        self.MA = [cp.Parameter((n, n)) for _ in pattern_rows]
        self.MC = [cp.Parameter((p, n)) for p in pattern_rows]
        self.M0 = cp.Parameter((n, n))
        top = [Y @ MA + Z @ MC for MA, MC, Z in zip(self.MA, self.MC, self.Z)] + [Y @ self.M0]
        k = len(top)
        zero = np.zeros((n, n))
        rows = [[Y, *top]]
        for i, B in enumerate(top):
            rows.append([B.T] + [Y if j == i else zero for j in range(k)])
        psi = cp.bmat(rows)
        self.size = size = n * (k + 1)
        self.problem = cp.Problem(
            cp.Maximize(self.t),
            [psi - self.t * np.eye(size) >> 0, Y << np.eye(n), self.t <= 1],
        )
        self.lock = threading.Lock()


#: Compiled problems kept, one per shape ``(n, rows of each pattern)``, least recently used first.
CACHE_SIZE = 8
#: Largest ``n`` whose compiled problem is kept.  Above, compiling is a small part of the solves
#: and the compiled program is large, so each :class:`StabilityLMI` compiles its own.
CACHED_MAX_N = 12
_CACHE: OrderedDict[tuple[int, tuple[int, ...]], _CompiledLMI] = OrderedDict()
_CACHE_LOCK = threading.Lock()


def _compiled(n: int, pattern_rows: tuple[int, ...]) -> _CompiledLMI:
    if n > CACHED_MAX_N:
        return _CompiledLMI(n, pattern_rows)
    key = (n, pattern_rows)
    with _CACHE_LOCK:
        c = _CACHE.get(key)
        if c is None:
            c = _CACHE[key] = _CompiledLMI(n, pattern_rows)
            while len(_CACHE) > CACHE_SIZE:
                _CACHE.popitem(last=False)
        _CACHE.move_to_end(key)
        return c
