"""Riccati and Lyapunov maps behind the classical bounds (docs/theory.md).

The modified algebraic Riccati equation (MARE) of Sinopoli et al. (2004) (eq. 17) and its
partial-loss generalization of Liu and Goldsmith (2004) (eq. 12, for any number ``m`` of
independent Bernoulli packets), the Lyapunov lower bound ``S_bar`` and the
MARE fixed point ``V_bar`` (Sinopoli et al. (2004), Theorems 3, 4 and 6(a); Liu and Goldsmith (2004),
Theorem 4).  The tighter bounds ``P_hat_N`` of Rohr, Marelli and Fu (2010)
build on this module and live in :mod:`kfio.riccati_bounds._phat`.

Everything here is float NumPy.  Certificates that are checked exactly live
in :mod:`kfio.riccati_bounds._certificate`.

Notation: packet ``s`` arrives with probability ``lambda_s``; an arrival
pattern is a bit mask ``S`` over the packets with probability
``pi(S) = prod_{s in S} lambda_s prod_{s not in S} (1 - lambda_s)``; ``C_S``
stacks the rows of ``C`` carried by the packets in ``S`` and ``R_SS`` is the
matching block of ``R``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Sequence

import numpy as np
import scipy.linalg

from .._budget import Budget
from ._stein import DENSE_MAX_N, solve_stein
from ._vech import congruence_matrix, unvech, vech

#: ``trace(V) / (1 + trace(Q))`` above which the monotone iteration is declared divergent.
DIVERGENCE_RATIO = 1e30


def pattern_weights(lambdas: Sequence[Any]) -> list[Any]:
    """Probabilities ``pi(S)`` of the ``2^m`` arrival patterns, indexed by bit mask.

    Bit ``s`` of the mask is set when packet ``s`` arrives.  Works for floats
    and for :class:`fractions.Fraction` (exact certificates).

    Examples
    --------
    >>> pattern_weights([0.5, 0.25])
    [0.375, 0.375, 0.125, 0.125]
    """
    return [
        math.prod((lam if mask >> s & 1 else 1 - lam for s, lam in enumerate(lambdas)), start=1)
        for mask in range(1 << len(lambdas))
    ]


def float_pattern_weights(lambdas: Sequence[Any]) -> list[float]:
    """``[float(w) for w in pattern_weights([Fraction(x) for x in lambdas])]``, in integers.

    Each probability is ``lambda_s = a_s / b_s`` exactly (a float's ``as_integer_ratio`` or a
    fraction's numerator and denominator), so ``pi(S) = prod_s c_s / prod_s b_s`` with
    ``c_s = a_s`` if packet ``s`` arrives and ``b_s - a_s`` if not.  Python's integer division
    ``N / D`` is correctly rounded, as is :class:`fractions.Fraction`'s ``float`` (which divides
    the reduced numerator by the reduced denominator: the same rational), so every float is the
    one of the exact weight, bit for bit, without the gcds of the fraction arithmetic.

    Examples
    --------
    >>> float_pattern_weights([0.5, Fraction(1, 3)])
    [0.3333333333333333, 0.3333333333333333, 0.16666666666666666, 0.16666666666666666]
    """
    ratios = [
        (x.numerator, x.denominator) if isinstance(x, (Fraction, int)) else Fraction(x).as_integer_ratio()
        for x in lambdas
    ]
    den = math.prod(b for _, b in ratios)
    return [
        math.prod((a if mask >> s & 1 else b - a for s, (a, b) in enumerate(ratios)), start=1) / den
        for mask in range(1 << len(ratios))
    ]


@dataclass(frozen=True)
class ArrivalModel:
    """A plant with its packets expanded into arrival patterns.

    Attributes
    ----------
    A, Q:
        Dynamics and process noise covariance, ``n x n``.
    C_S, R_S:
        ``C_S[k]``, ``R_S[k]``: rows of ``C`` and block of ``R`` for the pattern
        with mask ``k + 1`` (all non-empty patterns, in mask order).
    weights:
        ``pi(S)`` for masks ``0 .. 2^m - 1``; ``weights[0]`` is the probability
        that nothing arrives.
    """

    A: np.ndarray
    Q: np.ndarray
    C_S: tuple[np.ndarray, ...]
    R_S: tuple[np.ndarray, ...]
    weights: tuple[float, ...]

    @property
    def n(self) -> int:
        return int(self.A.shape[0])

    @property
    def loss_probability(self) -> float:
        """``pi(empty)``: the probability that no packet arrives."""
        return self.weights[0]

    def active(self) -> list[tuple[float, np.ndarray, np.ndarray]]:
        """``(pi(S), C_S, R_SS)`` for the non-empty patterns with ``pi(S) > 0``."""
        return [(w, c, r) for w, c, r in zip(self.weights[1:], self.C_S, self.R_S) if w > 0]


def subset_rows(row_groups: Sequence[Sequence[int]]) -> list[list[int]]:
    """Rows of ``C`` carried by each non-empty pattern, in mask order (mask ``k + 1``)."""
    m = len(row_groups)
    return [sorted(r for s in range(m) if mask >> s & 1 for r in row_groups[s]) for mask in range(1, 1 << m)]


def arrival_model(
    A: np.ndarray,
    C: np.ndarray,
    Q: np.ndarray,
    R: np.ndarray,
    row_groups: Sequence[Sequence[int]],
    lambdas: Sequence[float],
) -> ArrivalModel:
    """Build an :class:`ArrivalModel` from packets given as groups of rows of ``C``."""
    rows = subset_rows(row_groups)
    return ArrivalModel(
        A=np.asarray(A, float),
        Q=np.asarray(Q, float),
        C_S=tuple(np.asarray(C, float)[r, :] for r in rows),
        R_S=tuple(np.asarray(R, float)[np.ix_(r, r)] for r in rows),
        weights=tuple(float(w) for w in pattern_weights([float(x) for x in lambdas])),
    )


def one_packet_model(A: np.ndarray, C: np.ndarray, Q: np.ndarray, R: np.ndarray, lam: float) -> ArrivalModel:
    """The single-packet (Sinopoli et al. (2004)) case of :func:`arrival_model`."""
    C = np.atleast_2d(np.asarray(C, float))
    return arrival_model(A, C, Q, np.atleast_2d(R), [list(range(C.shape[0]))], [lam])


def spectral_radius(A: np.ndarray) -> float:
    """``rho(A) = max |eig(A)|``."""
    return float(np.max(np.abs(np.linalg.eigvals(A)))) if A.size else 0.0


def _sym(X: np.ndarray) -> np.ndarray:
    result: np.ndarray = 0.5 * (X + X.T)
    return result


# --- the maps ----------------------------------------------------------------------------------


def g_partial(X: np.ndarray, model: ArrivalModel) -> np.ndarray:
    r"""The generalized MARE of Liu and Goldsmith (2004), eq. 12, for ``m`` packets.

    .. math::

        g(X) = A X A' + Q - \sum_{S \ne \emptyset} \pi(S)\,
               A X C_S' (C_S X C_S' + R_{SS})^{-1} C_S X A'

    With one packet this is Sinopoli et al. (2004)'s ``g_lambda`` (eq. 17).
    """
    A = model.A
    AX = A @ X
    out = AX @ A.T + model.Q
    for w, C, R in model.active():
        AXC = AX @ C.T
        out -= w * AXC @ np.linalg.solve(C @ X @ C.T + R, AXC.T)
    return _sym(out)


def g_lambda(X: np.ndarray, A: np.ndarray, C: np.ndarray, Q: np.ndarray, R: np.ndarray, lam: float) -> np.ndarray:
    r"""Sinopoli et al. (2004)'s MARE, eq. 17: :math:`g_\lambda(X) = AXA' + Q - \lambda AXC'(CXC'+R)^{-1}CXA'`.

    Examples
    --------
    >>> import numpy as np
    >>> A, C, Q, R = np.array([[-1.25]]), np.array([[1.0]]), np.array([[1.0]]), np.array([[2.5]])
    >>> V = v_bar(A, C, Q, R, 0.4)
    >>> bool(np.allclose(g_lambda(V, A, C, Q, R, 0.4), V))
    True
    """
    return g_partial(X, one_packet_model(A, C, Q, R, lam))


def gains(X: np.ndarray, model: ArrivalModel) -> tuple[np.ndarray, ...]:
    """Optimal gains ``K_S = -A X C_S' (C_S X C_S' + R_SS)^-1`` (Liu and Goldsmith (2004), after eq. 16).

    One gain per non-empty pattern, in mask order; ``g(X) = phi(K, X)`` with
    these gains (Sinopoli et al. (2004), Lemma 1(a); Liu and Goldsmith (2004), eq. 17).
    """
    AX = model.A @ X
    return tuple(-np.linalg.solve(C @ X @ C.T + R, C @ AX.T).T for C, R in zip(model.C_S, model.R_S))


def closed_loop_terms(model: ArrivalModel, K: Sequence[np.ndarray]) -> list[tuple[float, np.ndarray]]:
    r"""The terms ``(pi(S), F_S)`` of :math:`\mathcal L_K` with ``pi(S) > 0`` (``F_empty = A``, ``F_S = A + K_S C_S``)."""
    terms = [(model.weights[0], model.A)] if model.weights[0] > 0 else []
    return terms + [(w, model.A + Ks @ C) for w, Ks, C in zip(model.weights[1:], K, model.C_S) if w > 0]


def closed_loop_operator(model: ArrivalModel, K: Sequence[np.ndarray]) -> np.ndarray:
    r"""Matrix of :math:`\mathcal L_K(X) = \pi(\emptyset) A X A' + \sum_S \pi(S) F_S X F_S'` on ``vech``.

    ``F_S = A + K_S C_S``: Sinopoli et al. (2004), Lemma 3; Liu and Goldsmith (2004), the linear part of eq. 16.
    """
    L = model.weights[0] * congruence_matrix(model.A)
    for w, Ks, C in zip(model.weights[1:], K, model.C_S):
        if w > 0:
            L = L + w * congruence_matrix(model.A + Ks @ C)
    return L


def policy_evaluation(
    model: ArrivalModel, K: Sequence[np.ndarray], start: np.ndarray | None = None
) -> np.ndarray | None:
    r"""Solve :math:`X = \phi(K, X) = \mathcal L_K(X) + Q + \sum_S \pi(S) K_S R_{SS} K_S'`.

    Returns ``None`` unless ``K`` is mean-square stabilizing, i.e. unless
    :math:`\rho(\mathcal L_K) < 1`; that is decided by solving also
    ``Y = L_K(Y) + I`` and testing ``Y > 0`` (for a positive operator,
    ``Y = sum_k L_K^k(I) > 0`` exists iff ``rho(L_K) < 1``).  When it is, the
    solution satisfies ``X = phi(K, X) >= g(X)``, so ``X >= V_bar``
    (Sinopoli et al. (2004), Theorem 1 and Lemma 1(b)): an upper bound.

    Above :data:`kfio.riccati_bounds._stein.DENSE_MAX_N` states the equations are solved
    in ``O(n^3)`` work per operator application (:func:`kfio.riccati_bounds._stein.solve_stein`),
    else (or where that declines) on ``vech``.
    There, when ``W > 0``, ``X > 0`` replaces the test on ``Y``: ``X - L_K(X) = W > 0`` with
    ``X > 0`` gives ``rho(L_K) < 1`` (Lyapunov's theorem for positive operators), and
    ``rho(L_K) < 1`` gives ``X = sum_k L_K^k(W) > 0``.  ``start`` (the previous evaluation of a
    policy iteration) is GMRES's first guess there; the dense solve does not use it.
    """
    n = model.n
    W = model.Q.copy()
    for w, Ks, R in zip(model.weights[1:], K, model.R_S):
        if w > 0:
            W += w * Ks @ R @ Ks.T
    if n > DENSE_MAX_N:
        terms = closed_loop_terms(model, K)
        if np.linalg.eigvalsh(_sym(W)).min() > 0:
            # W > 0: X > 0 with X - L_K(X) = W > 0 is itself the proof that rho(L_K) < 1, no Y needed
            fast = solve_stein(terms, [W], [start])
            if fast is not None:
                return fast[0] if np.linalg.eigvalsh(fast[0]).min() > 0 else None
        else:
            fast = solve_stein(terms, [W, np.eye(n)])
            if fast is not None:
                return fast[0] if np.linalg.eigvalsh(fast[1]).min() > 0 else None
    M = np.eye(n * (n + 1) // 2) - closed_loop_operator(model, K)
    try:
        sol = np.linalg.solve(M, np.column_stack([vech(_sym(W)), vech(np.eye(n))]))
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(sol)) or np.linalg.eigvalsh(unvech(sol[:, 1], n)).min() <= 0:
        return None
    return unvech(sol[:, 0], n)


# --- S_bar: the Lyapunov lower bound ------------------------------------------------------------


def s_bar(A: np.ndarray, Q: np.ndarray, loss_probability: float) -> np.ndarray | None:
    r"""Sinopoli et al. (2004)'s lower bound ``S_bar``: the solution of :math:`S = p\, A S A' + Q`.

    ``p`` is the probability that nothing arrives (``1 - lambda`` for one
    packet, ``prod_s (1 - lambda_s)`` for independent packets, Liu and Goldsmith (2004)
    Theorem 4).  The solution is the limit of ``S_{t+1} = p A S_t A' + Q``
    from ``S_0 = 0`` and lower-bounds ``lim E[P_t]`` (Sinopoli et al. (2004), Theorem 4).

    Returns
    -------
    numpy.ndarray or None
        ``None`` when ``p rho(A)^2 >= 1``: the Lyapunov operator is not
        stable, the sequence ``S_t`` diverges (whenever ``(A, Q^1/2)`` is
        controllable) and so does ``E[P_t]`` (Sinopoli et al. (2004), Theorem 3).

    Examples
    --------
    >>> import numpy as np
    >>> S = s_bar(np.array([[-1.25]]), np.array([[1.0]]), 0.6)
    >>> round(float(S[0, 0]), 12)  # 1 / (1 - 0.6 * 1.5625)
    16.0
    """
    A = np.asarray(A, float)
    if loss_probability * spectral_radius(A) ** 2 >= 1.0:
        return None
    S = scipy.linalg.solve_discrete_lyapunov(np.sqrt(loss_probability) * A, np.asarray(Q, float))
    return _sym(S)


def lyapunov_residual(S: np.ndarray, A: np.ndarray, Q: np.ndarray, loss_probability: float) -> float:
    """``||S - p A S A' - Q||_F / max(1, ||S||_F)``: the substitute-back check of :func:`s_bar`."""
    r = S - loss_probability * A @ S @ A.T - Q
    return float(np.linalg.norm(r) / max(1.0, float(np.linalg.norm(S))))


def mare_residual(V: np.ndarray, model: ArrivalModel) -> float:
    """``||g(V) - V||_F / max(1, ||V||_F)``."""
    return float(np.linalg.norm(g_partial(V, model) - V) / max(1.0, float(np.linalg.norm(V))))


# --- V_bar: the MARE fixed point ----------------------------------------------------------------


@dataclass(frozen=True)
class VBarIteration:
    """Outcome of :func:`solve_v_bar`.

    Attributes
    ----------
    matrix:
        ``V_bar`` (the upper end of the bracket), or ``None``.
    lower:
        The last monotone iterate ``g^k(0) <= V_bar``, or ``None``.
    iterations:
        Steps of the monotone iteration from 0.
    newton_steps:
        Policy-iteration steps from above.
    residual:
        :func:`mare_residual` of ``matrix``.
    bracket_gap:
        ``||matrix - lower||_F / ||matrix||_F``: ``lower <= V_bar <= matrix``.
    reason:
        Why ``matrix`` is ``None``.
    """

    matrix: np.ndarray | None
    lower: np.ndarray | None
    iterations: int
    newton_steps: int
    residual: float | None
    bracket_gap: float | None
    reason: str | None = None


def _newton_from(model: ArrivalModel, V: np.ndarray, max_steps: int = 60) -> tuple[np.ndarray | None, int]:
    """Policy iteration (Newton's method on the MARE) started from the gains of ``V``.

    Each step evaluates the current gains (:func:`policy_evaluation`) and
    re-optimizes them; the iterates decrease monotonically to ``V_bar``
    (Sinopoli et al. (2004), Lemma 1(b) and the proof of Theorem 1).
    """
    X = policy_evaluation(model, gains(V, model))
    if X is None:
        return None, 0
    for step in range(1, max_steps + 1):
        X_next = policy_evaluation(model, gains(X, model), X)
        if X_next is None:  # rounding near the threshold; keep the last valid upper bound
            return X, step
        done = np.linalg.norm(X_next - X) <= 1e-15 * np.linalg.norm(X)
        X = X_next
        if done:
            return X, step
    return X, max_steps


#: The latest answers of :func:`solve_v_bar` (the model's bytes and the options -> the answer): ``kfio bounds``
#: asks for the same ``V_bar`` twice, for the covariance bounds and as ``P_hat_1`` (Rohr, Marelli and Fu 2010).
_V_BAR_CACHE: dict[tuple[Any, ...], VBarIteration] = {}
_V_BAR_CACHE_SIZE = 4


def _model_key(model: ArrivalModel) -> tuple[Any, ...]:
    arrays = (model.A, model.Q, *model.C_S, *model.R_S)
    return tuple((a.shape, np.ascontiguousarray(a, float).tobytes()) for a in arrays) + (model.weights,)


def _copy(it: VBarIteration) -> VBarIteration:
    """The same answer with its own arrays (callers may write into them)."""
    return dataclasses.replace(
        it,
        matrix=None if it.matrix is None else it.matrix.copy(),
        lower=None if it.lower is None else it.lower.copy(),
    )


def solve_v_bar(
    model: ArrivalModel,
    *,
    rtol: float = 1e-12,
    max_iter: int = 200_000,
    budget: Budget | None = None,
) -> VBarIteration:
    """``V_bar``, the fixed point of :func:`g_partial`, by monotone iteration.

    The answer is remembered for the last few models (a deterministic computation, so a repeated
    request gets the same floats; the budget is not ticked again).

    The iteration ``V_{k+1} = g(V_k)`` from ``V_0 = 0`` increases
    monotonically to ``V_bar`` when it exists (Sinopoli et al. (2004), Theorem 6(a) and the
    proof of Theorem 1; Liu and Goldsmith (2004), Theorem 6(a)).  Near the critical
    probability it converges slowly, so at ``k = 16, 32, 64, ...`` the gains
    of ``V_k`` seed a policy iteration from above (Newton's method), which
    decreases monotonically to ``V_bar``.  The two sequences bracket
    ``V_bar``; we stop when the upper one has converged and satisfies the
    MARE to ``rtol``.

    Returns a :class:`VBarIteration` whose ``matrix`` is ``None`` when the
    iteration diverges: at once when ``pi(empty) rho(A)^2 >= 1`` (then
    ``V_k >= S_k`` diverges, Sinopoli et al. (2004) Lemma 1(f)), or when the trace
    explodes, or when ``max_iter`` steps neither converge nor diverge.
    """
    key = (_model_key(model), rtol, max_iter)
    hit = _V_BAR_CACHE.get(key)
    if hit is None:
        hit = _solve_v_bar(model, rtol, max_iter, budget)
        if len(_V_BAR_CACHE) >= _V_BAR_CACHE_SIZE:
            _V_BAR_CACHE.clear()  # one atomic call: safe with the service's threads (no iteration over the dict)
        _V_BAR_CACHE[key] = hit
    return _copy(hit)


def _solve_v_bar(model: ArrivalModel, rtol: float, max_iter: int, budget: Budget | None) -> VBarIteration:
    p0 = model.loss_probability
    if p0 * spectral_radius(model.A) ** 2 >= 1.0:
        return VBarIteration(None, None, 0, 0, None, None, "pi(empty) rho(A)^2 >= 1: the lower bound S_bar diverges")
    n = model.n
    V = np.zeros((n, n))
    cap = DIVERGENCE_RATIO * (1.0 + float(np.trace(model.Q)))
    next_try = 16
    for k in range(1, max_iter + 1):
        if budget is not None:
            budget.tick("V_bar iteration")
        V_next = g_partial(V, model)
        if not np.all(np.isfinite(V_next)) or np.trace(V_next) > cap:
            return VBarIteration(None, None, k, 0, None, None, "the MARE iteration from 0 diverges")
        stalled = np.linalg.norm(V_next - V) <= 1e-15 * max(1.0, float(np.linalg.norm(V_next)))
        V = V_next
        if k == next_try or stalled or k == max_iter:
            next_try *= 2
            upper, steps = _newton_from(model, V)
            if upper is not None:
                res = mare_residual(upper, model)
                if res <= rtol or stalled:
                    gap = float(np.linalg.norm(upper - V) / max(1e-300, float(np.linalg.norm(upper))))
                    return VBarIteration(upper, V, k, steps, res, gap)
    return VBarIteration(
        None, V, max_iter, 0, None, None, f"the MARE iteration neither converged nor diverged in {max_iter} steps"
    )


def v_bar(A: np.ndarray, C: np.ndarray, Q: np.ndarray, R: np.ndarray, lam: float) -> np.ndarray | None:
    """Sinopoli et al. (2004)'s upper bound ``V_bar = g_lambda(V_bar)`` (Theorem 4), or ``None`` if it diverges.

    Thin wrapper of :func:`solve_v_bar` for one packet arriving with
    probability ``lam``; see there for the algorithm and the divergence test.

    Examples
    --------
    >>> import numpy as np
    >>> V = v_bar(np.array([[-1.25]]), np.array([[1.0]]), np.array([[1.0]]), np.array([[2.5]]), 0.4)
    >>> round(float(V[0, 0]), 6)
    39.512342
    """
    return solve_v_bar(one_packet_model(A, C, Q, R, lam)).matrix
