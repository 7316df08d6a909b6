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
  decided exactly (diagonal dominance, directly or after an integer congruence
  chosen from a float Cholesky, else Sylvester's criterion by a fraction-free LU
  over the integers: :func:`positive_definite_exact`).
* ``"eigenvalue_margin"`` (prefilter, and fallback): NumPy eigenvalues of
  ``X`` and ``M`` exceed an explicit rounding allowance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Iterable, Sequence

import numpy as np

from .._reporting import ReportPart
from ..model import Matrix
from ._riccati import ArrivalModel, closed_loop_operator, closed_loop_terms
from ._stein import DENSE_MAX_N, solve_near, solve_stein
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


def lyapunov_certificate(
    model: ArrivalModel, K: Sequence[np.ndarray], near: Sequence[Any] | None = None
) -> np.ndarray | None:
    """The ``X`` with ``X - L_K(X) = I``, or ``None`` if singular.

    A ``vech`` linear solve, or above :data:`kfio.riccati_bounds._stein.DENSE_MAX_N` states
    :func:`kfio.riccati_bounds._stein.solve_stein` (the dense solve where that declines).
    ``near`` (the LU factors of a nearby operator's ``vech`` matrix, and a first guess: what the
    slide's last stability test factored) makes it :func:`kfio.riccati_bounds._stein.solve_near`
    first: near the threshold GMRES with the single-term preconditioner stalls, and the dense
    solve then forms the operator afresh.  Either way the certificate is then re-proved
    exactly, whatever solved for ``X``.
    """
    n = model.n
    if n > DENSE_MAX_N:
        terms = closed_loop_terms(model, K)
        if near:
            h = solve_near(terms, near[0], vech(np.eye(n)), near[1])
            if h is not None:
                return unvech(h, n)
        sol = solve_stein(terms, [np.eye(n)])
        if sol is not None:
            return sol[0]
    M = np.eye(n * (n + 1) // 2) - closed_loop_operator(model, K)
    try:
        h = np.linalg.solve(M, vech(np.eye(n)))
    except np.linalg.LinAlgError:
        return None
    return unvech(h, n) if np.all(np.isfinite(h)) else None


def _float_residual(
    model: ArrivalModel, K: Sequence[np.ndarray], X: np.ndarray, scaled: bool = True
) -> tuple[np.ndarray, float]:
    """``M = X - L_K(X)`` in floats and the scale of the terms that were added up.

    ``scaled=False`` skips the scale (three spectral norms, ``nan`` returned): the exact route
    only reads the signs of ``M``'s eigenvalues.  ``M`` is the same float matrix either way.
    """
    A = model.A
    M = X - model.weights[0] * A @ X @ A.T
    scale = 1.0 + model.weights[0] * np.linalg.norm(A, 2) ** 2 if scaled else math.nan
    for w, Ks, C in zip(model.weights[1:], K, model.C_S):
        if w > 0:
            F = A + Ks @ C
            M = M - w * F @ X @ F.T
            if scaled:
                scale += w * np.linalg.norm(F, 2) ** 2
    return 0.5 * (M + M.T), float(scale * np.linalg.norm(X, 2)) if scaled else math.nan


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


def _fmpq_mat(rows: Iterable[Iterable[float | Fraction]]) -> Any:
    """A python-flint ``fmpq_mat`` from rows of floats (exactly: each float is a dyadic rational) or Fractions."""
    import flint

    def q(x: float | Fraction) -> Any:
        if isinstance(x, Fraction):
            return flint.fmpq(x.numerator, x.denominator)
        a, b = float(x).as_integer_ratio()
        return flint.fmpq(a, b)

    matrix = [list(r) for r in rows]
    return flint.fmpq_mat(len(matrix), len(matrix[0]) if matrix else 0, [q(x) for r in matrix for x in r])


def positive_definite_exact(M: Any) -> bool:
    """Decide ``M > 0`` exactly for a symmetric ``fmpq_mat``.

    ``M`` times the common denominator of its entries is a symmetric integer matrix ``N``
    (``M = N / den``, ``den > 0``), positive definite iff ``M`` is.  Two exact sufficient
    tests run first (:func:`positive_definite_by_congruence`), and only when neither proves
    ``N > 0`` does Sylvester's criterion decide (:func:`positive_definite_sylvester`).  Each of
    the three is a theorem applied in integer arithmetic, so the answer is the same whichever
    decides; only the time differs.
    """
    n = M.nrows()
    if n == 0:
        return True
    num, _ = M.numer_denom()  # M = num / den with den > 0
    return positive_definite_by_congruence(num) or positive_definite_sylvester(num)


def positive_definite_sylvester(N: Any) -> bool:
    """Decide ``N > 0`` exactly for a symmetric ``fmpz_mat`` (Sylvester's criterion).

    The fraction-free (Bareiss) LU of ``N``, ``fmpz_mat.fflu``, has the leading principal
    minors on the diagonal of ``U`` as long as no row exchange was needed, and a row exchange
    happens only when a leading minor vanishes, which a positive definite matrix never has.
    So ``N > 0`` iff the permutation is the identity and every ``U[k, k] > 0``.  Integer
    arithmetic throughout (no gcds); the entries grow to ``n`` times their length.
    """
    n = N.nrows()
    if n == 0:
        return True
    P, _, _, U = N.fflu()
    return bool(P.is_one()) and all(U[k, k] > 0 for k in range(n))


def _dominant(rows: list[list[int]], shifts: Sequence[int] | None = None) -> bool:
    """Whether ``S N S`` is strictly diagonally dominant with a positive diagonal, ``S = diag(2^-shifts)``.

    Row ``i`` of ``S N S`` times ``2^(shifts_i + E)`` (``E = max shifts``) is
    ``N_ij 2^(E - shifts_j)``: integers, so the comparison is exact.
    """
    n = len(rows)
    e = list(shifts) if shifts is not None else [0] * n
    top = max(e)
    for i, row in enumerate(rows):
        d = row[i] << (top - e[i])
        if d <= 0:
            return False
        off = sum(abs(x) << (top - e[j]) for j, x in enumerate(row) if j != i)
        if off >= d:
            return False
    return True


def positive_definite_by_congruence(N: Any) -> bool:
    """``True`` if ``N > 0`` (a symmetric ``fmpz_mat``) is proved by diagonal dominance after a congruence.

    Two exact sufficient tests; ``False`` means "not proved", never "not positive definite".

    1. ``N`` itself is strictly diagonally dominant with a positive diagonal: then every
       Gershgorin disc lies in the right half-line, so every eigenvalue of the symmetric ``N``
       is positive (the Levy-Desplanques theorem; Horn and Johnson (2013), Theorem 6.1.10).
       The certificates' ``X - L_K(X)`` are close to ``I`` and pass here.
    2. Else a float Cholesky ``N ~ L L'`` gives ``G ~ L^-1``, rounded to an integer lower
       triangular ``Z`` (row ``i`` scaled by ``2^e_i``).  When ``Z`` has a non-zero diagonal it is
       non-singular, so by Sylvester's law of inertia (Horn and Johnson (2013), Theorem 4.5.8) ``N > 0`` iff ``Z N Z' > 0``, formed
       exactly in ``fmpz_mat``; and ``Z N Z' = D (G N G' + E) D`` with ``D = diag(2^e_i)`` and
       ``G N G' ~ I``, so ``D^-1 Z N Z' D^-1`` is tested for diagonal dominance as in 1.  The
       floats only choose ``Z``; whatever their rounding, the conclusion is about the exact
       ``Z N Z'``.  A badly conditioned ``N`` (the certificates' ``X`` near the threshold) passes
       here too as long as ``cond(N)`` is well below ``1 / eps``.
    """
    import flint
    import scipy.linalg

    n = N.nrows()
    rows = [[int(x) for x in r] for r in N.tolist()]
    if _dominant(rows):
        return True
    bits = max(abs(x).bit_length() for r in rows for x in r)
    shift = max(0, bits - 900)  # floats stay finite; they only guide the choice of Z
    F = np.array([[float(x >> shift) for x in r] for r in rows])
    try:
        L = np.linalg.cholesky(F)
    except np.linalg.LinAlgError:
        return False
    G = scipy.linalg.solve_triangular(L, np.eye(n), lower=True, check_finite=False)
    if not np.all(np.isfinite(G)):
        return False
    _, ex = np.frexp(np.max(np.abs(G), axis=1))
    e = (52 - ex).astype(int)  # row i of G times 2^e_i has entries below 2^52 in size
    Z = np.tril(np.rint(np.ldexp(G, e[:, None])))
    if np.any(np.diag(Z) == 0):
        return False
    Zq = flint.fmpz_mat([[int(x) for x in r] for r in Z])
    P = Zq * N * Zq.transpose()
    return _dominant([[int(x) for x in r] for r in P.tolist()], [int(x) for x in e])


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
    near: Sequence[Any] | None = None,
) -> StabilityCertificate | None:
    """Re-check gains ``K`` (user coordinates) at ``lambdas``; a certificate or ``None``.

    ``near``: see :func:`lyapunov_certificate`.

    ``model`` carries the same probabilities as floats.  A float test runs
    first (cheap, and it rejects gains that do not stabilize): with ``exact``
    the signs of the eigenvalues of ``X`` and ``X - L_K(X)``, then the exact
    check decides; without, :func:`float_check` with its rounding allowance
    is the verdict.
    """
    X = lyapunov_certificate(model, K, near)
    if X is None:
        return None
    if exact:  # the float test only has to reject gains that do not stabilize: signs, no allowance
        M, _ = _float_residual(model, K, X, scaled=False)
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
