"""Re-checking LMI certificates ourselves (docs/theory.md, "Numerical soundness").

A solver's "feasible" is not a proof: near the threshold the LMI margin is
far below the solver's tolerance.  What we prove instead is statement (b) of
Sinopoli et al. (2004)'s Theorem 5 (Liu and Goldsmith (2004)'s Theorem 5(b) for ``m`` packets):

    there are gains ``K_S`` and ``X > 0`` with ``X - L_K(X) > 0``,
    ``L_K(X) = pi(empty) A X A' + sum_S pi(S) (A + K_S C_S) X (A + K_S C_S)'``.

Then ``t X > phi(K, t X)`` for ``t`` large enough (the constant terms
``Q + K R K'`` are absorbed), so Theorem 5(a)-(c) hold: the LMI is feasible
at these arrival probabilities and ``lambda_c <= lambda`` (Theorem 3).

The gains come from the solver (``K_S = Y^-1 Z_S``); ``X`` is recomputed for
those gains by solving ``X - L_K(X) = I`` (:func:`lyapunov_certificate`),
which turns a tiny LMI margin into an exactly checkable statement.  Two
checks, reported as the certificate's ``method``:

* ``"exact_rational"``: ``K_S`` and ``X`` are rationalized (every float is a
  dyadic rational), ``M = X - L_K(X)`` is formed over ``Q`` with the user's
  exact ``A``, ``C`` and arrival probabilities, and ``X > 0``, ``M > 0`` are
  decided exactly (Sylvester's criterion by a fraction-free LU over the
  integers, :func:`positive_definite_exact`).
* ``"eigenvalue_margin"`` (prefilter, and fallback): NumPy eigenvalues of
  ``X`` and ``M`` exceed an explicit rounding allowance.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Sequence

import numpy as np

from .._reporting import ReportPart
from ..model import Matrix
from ._riccati import ArrivalModel, closed_loop_operator, closed_loop_terms
from ._stein import DENSE_MAX_N, solve_stein
from ._vech import unvech, vech

#: Rounding allowance of the float check, in units of ``n * eps * scale``.
FLOAT_CHECK_FACTOR = 1e3


@dataclass(frozen=True)
class ExactPlant:
    """The user's exact ``A`` and ``C_S`` (one per non-empty pattern, mask order)."""

    A: Matrix
    C_S: tuple[Matrix, ...]


@dataclass(frozen=True)
class StabilityCertificate(ReportPart):
    """A re-checked proof that the LMI is feasible at ``lambdas``.

    Attributes
    ----------
    lambdas:
        Exact arrival probabilities (one per packet).
    method:
        ``"exact_rational"`` or ``"eigenvalue_margin"``.
    margin:
        ``lambda_min(X - L_K(X)) / lambda_max(X)`` (float evaluation): scale-free,
        and since ``X - L_K(X) >= margin X`` it bounds the closed-loop
        operator, ``rho(L_K) <= 1 - margin``.
    solver_margin:
        The solver's optimal ``t`` in ``Psi >= t I`` (its own claim).
    X, K:
        The certificate, in the user's coordinates.
    route:
        What produced the gains ``K``: ``"LMI"``, ``"annihilating gains"`` or
        ``"MARE gains by policy iteration"`` (the check is the same for all).
    """

    lambdas: tuple[Fraction, ...]
    method: str
    margin: float
    solver_margin: float | None
    X: np.ndarray
    K: tuple[np.ndarray, ...]
    route: str = "LMI"


def lyapunov_certificate(model: ArrivalModel, K: Sequence[np.ndarray]) -> np.ndarray | None:
    """The ``X`` with ``X - L_K(X) = I``, or ``None`` if singular.

    A ``vech`` linear solve, or above :data:`kfio.riccati_bounds._stein.DENSE_MAX_N` states
    :func:`kfio.riccati_bounds._stein.solve_stein` (the dense solve where that declines).
    Either way the certificate is then re-proved exactly, whatever solved for ``X``.
    """
    n = model.n
    if n > DENSE_MAX_N:
        sol = solve_stein(closed_loop_terms(model, K), [np.eye(n)])
        if sol is not None:
            return sol[0]
    M = np.eye(n * (n + 1) // 2) - closed_loop_operator(model, K)
    try:
        h = np.linalg.solve(M, vech(np.eye(n)))
    except np.linalg.LinAlgError:
        return None
    return unvech(h, n) if np.all(np.isfinite(h)) else None


def _float_residual(model: ArrivalModel, K: Sequence[np.ndarray], X: np.ndarray) -> tuple[np.ndarray, float]:
    """``M = X - L_K(X)`` in floats and the scale of the terms that were added up."""
    A = model.A
    M = X - model.weights[0] * A @ X @ A.T
    scale = 1.0 + model.weights[0] * np.linalg.norm(A, 2) ** 2
    for w, Ks, C in zip(model.weights[1:], K, model.C_S):
        if w > 0:
            F = A + Ks @ C
            M = M - w * F @ X @ F.T
            scale += w * np.linalg.norm(F, 2) ** 2
    return 0.5 * (M + M.T), float(scale * np.linalg.norm(X, 2))


def float_check(model: ArrivalModel, K: Sequence[np.ndarray], X: np.ndarray) -> float | None:
    """Scale-free margin if ``X > 0`` and ``X - L_K(X) > 0`` beyond rounding, else ``None``."""
    n = model.n
    M, scale = _float_residual(model, K, X)
    allowance = FLOAT_CHECK_FACTOR * n * np.finfo(float).eps * scale
    ex = np.linalg.eigvalsh(0.5 * (X + X.T))
    em = np.linalg.eigvalsh(M)
    if ex[0] <= allowance or em[0] <= allowance:
        return None
    return float(em[0] / ex[-1])


def _fmpq_mat(rows) -> Any:
    """A python-flint ``fmpq_mat`` from rows of floats (exactly: each float is a dyadic rational) or Fractions."""
    import flint

    def q(x) -> Any:
        if isinstance(x, Fraction):
            return flint.fmpq(x.numerator, x.denominator)
        a, b = float(x).as_integer_ratio()
        return flint.fmpq(a, b)

    rows = [list(r) for r in rows]
    return flint.fmpq_mat(len(rows), len(rows[0]) if rows else 0, [q(x) for r in rows for x in r])


def positive_definite_exact(M: Any) -> bool:
    """Decide ``M > 0`` exactly for a symmetric ``fmpq_mat`` (Sylvester's criterion).

    ``M`` times the common denominator of its entries is an integer matrix
    with the same leading principal minors' signs; its fraction-free
    (Bareiss) LU, ``fmpz_mat.fflu``, has those minors on the diagonal of
    ``U`` as long as no row exchange was needed, and a row exchange happens
    only when a leading minor vanishes, which a positive definite matrix
    never has.  So ``M > 0`` iff the permutation is the identity and every
    ``U[k, k] > 0``.  Integer arithmetic throughout (no gcds).
    """
    n = M.nrows()
    if n == 0:
        return True
    num, _ = M.numer_denom()  # M = num / den with den > 0
    P, _, _, U = num.fflu()
    return bool(P.is_one()) and all(U[k, k] > 0 for k in range(n))


def exact_check(plant: ExactPlant, weights: Sequence[Fraction], K: Sequence[np.ndarray], X: np.ndarray) -> bool:
    """Decide ``X > 0`` and ``X - L_K(X) > 0`` exactly, with ``K``, ``X`` rationalized.

    ``weights`` are the exact pattern probabilities ``pi(S)`` (mask order,
    ``weights[0] = pi(empty)``).  The symmetric part of ``X`` is used (the
    float ``X`` is symmetric up to rounding; the statement is about it).
    The products are formed over ``Q`` with python-flint ``fmpq_mat`` and
    definiteness is decided by :func:`positive_definite_exact`.
    """
    import flint

    Xq = _fmpq_mat(0.5 * (X + X.T))
    if not positive_definite_exact(Xq):
        return False
    Aq = _fmpq_mat(plant.A)
    M = Xq - (Aq * Xq * Aq.transpose()) * flint.fmpq(weights[0].numerator, weights[0].denominator)
    for w, Ks, Cs in zip(weights[1:], K, plant.C_S):
        if w == 0:
            continue
        F = Aq + _fmpq_mat(np.atleast_2d(Ks)) * _fmpq_mat(Cs)
        M = M - (F * Xq * F.transpose()) * flint.fmpq(w.numerator, w.denominator)
    return positive_definite_exact(M)


def certify(
    model: ArrivalModel,
    plant: ExactPlant,
    lambdas: Sequence[Fraction],
    weights: Sequence[Fraction],
    K: Sequence[np.ndarray],
    solver_margin: float | None,
    exact: bool = True,
    route: str = "LMI",
) -> StabilityCertificate | None:
    """Re-check gains ``K`` (user coordinates) at ``lambdas``; a certificate or ``None``.

    ``model`` carries the same probabilities as floats.  A float test runs
    first (cheap, and it rejects gains that do not stabilize): with ``exact``
    the signs of the eigenvalues of ``X`` and ``X - L_K(X)``, then the exact
    check decides; without, :func:`float_check` with its rounding allowance
    is the verdict.
    """
    X = lyapunov_certificate(model, K)
    if X is None:
        return None
    if exact:  # the float test only has to reject gains that do not stabilize: signs, no allowance
        M, _ = _float_residual(model, K, X)
        ex, em = np.linalg.eigvalsh(0.5 * (X + X.T)), np.linalg.eigvalsh(M)
        margin = float(em[0] / ex[-1]) if ex[0] > 0 and em[0] > 0 else None
    else:
        margin = float_check(model, K, X)
    if margin is None:
        return None
    method = "eigenvalue_margin"
    if exact:
        if not exact_check(plant, weights, K, X):
            return None
        method = "exact_rational"
    return StabilityCertificate(tuple(lambdas), method, margin, solver_margin, X, tuple(K), route)
