r"""The generalized Stein equation of the bounds' search, in ``O(n^3)`` work per operator application.

Policy evaluation, the certificates' ``X - L_K(X) = I`` and the continuation's stability test
all solve

.. math::

    X - \mathcal L(X) = W, \qquad \mathcal L(X) = \sum_i w_i M_i X M_i',

one term per arrival pattern (``M_0 = A``, ``M_S = A + K_S C_S``; Sinopoli et al. (2004),
Lemma 3; Liu and Goldsmith (2004), eq. 16).  On ``vech`` this is an ``m x m`` system with
``m = n(n+1)/2``: ``O(n^6)`` work and an ``O(n^4)`` matrix per term, 820 unknowns at ``n = 40``.
With several terms it is a *generalized* Stein equation, which the Bartels-Stewart method does
not solve directly.  Above :data:`DENSE_MAX_N` states it is solved here by GMRES (Saad and
Schultz 1986) on the operator itself, ``X -> X - sum_i w_i M_i X M_i'`` (two ``n x n`` products
per term), preconditioned by the exact inverse of the single-term Stein equation
``X - w_d M_d X M_d' = R`` of the dominant term (the largest ``w_i rho(M_i)^2``): with
``M_d = V D V^-1``, ``X = V [(V^-1 R V^-H)_jk / (1 - w_d d_j conj(d_k))] V^H``.  For positive
operators ``X - L(X) = P(X) - (P(X) - X + L(X))`` is a regular splitting, so the preconditioned
fixed-point iteration already converges exactly when ``rho(L) < 1``; GMRES accelerates it.

Every answer is substituted back: unless ``||X - L(X) - W||_F`` is at the level of
:data:`RESIDUAL_RTOL` times the size of the terms, the dense ``vech`` solve answers instead
(the callers' fallback), so the result is always that of the dense solve up to rounding.  Up to
:data:`DENSE_MAX_N` states the dense solve answers directly, so the floats of every request
of that size are the dense solve's.
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np
import scipy.linalg

from ._vech import unvech, vech_layout

#: Up to this many states the dense ``vech`` solve answers: it is faster there (a whole
#: ``kfio bounds`` request at ``n = 20``: 1.1 s against 2.0 s; at ``n = 30``: 3.9 s against 3.3 s).
DENSE_MAX_N = 24
#: GMRES's relative residual target and the substitute-back check's, relative to the terms' size.
RESIDUAL_RTOL = 1e-12
#: GMRES's restart length, and the restarts allowed before the dense solve takes over.
RESTART, MAX_RESTARTS = 40, 10
#: ``w_d rho(M_d)^2`` at or above which a term cannot precondition (its own Stein equation is singular).
PRECONDITIONER_MAX_RADIUS = 0.999
#: Condition number of the eigenvector matrix ``V`` above which the preconditioner is not used.
MAX_EIGENVECTOR_CONDITION = 1e8

Term = tuple[float, np.ndarray]


def apply(terms: Sequence[Term], X: np.ndarray) -> np.ndarray:
    """``L(X) = sum_i w_i M_i X M_i'``."""
    out = np.zeros_like(X)
    for w, M in terms:
        out += w * (M @ X @ M.T)
    return out


#: The latest eigendecompositions (``M``'s bytes -> ``eig(M)``): the open-loop ``A`` is a term of every equation.
_EIG_CACHE: dict[tuple[tuple[int, ...], bytes], tuple[np.ndarray, np.ndarray]] = {}
_EIG_CACHE_SIZE = 8


def _eig(M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``numpy.linalg.eig(M)``, remembered for the last few ``M`` (the same call, so the same floats; read-only)."""
    key = (M.shape, np.ascontiguousarray(M).tobytes())
    hit = _EIG_CACHE.get(key)
    if hit is None:
        hit = np.linalg.eig(M)
        if len(_EIG_CACHE) >= _EIG_CACHE_SIZE:
            _EIG_CACHE.clear()  # one atomic call: safe with the service's threads (no iteration over the dict)
        _EIG_CACHE[key] = hit
    return hit


class _SteinInverse:
    """The exact inverse of ``X -> X - w M X M'`` through the eigenvectors of ``M`` (or ``None`` if unusable)."""

    def __init__(self, w: float, M: np.ndarray) -> None:
        d, V = _eig(M)
        self.usable = bool(np.all(np.isfinite(V))) and np.linalg.cond(V) < MAX_EIGENVECTOR_CONDITION
        if self.usable:
            self.V, self.Vh = V, V.conj().T
            self.Vi = np.linalg.inv(V)
            self.Vih = self.Vi.conj().T
            self.denom = 1.0 - w * d[:, None] * d.conj()[None, :]

    def __call__(self, R: np.ndarray) -> np.ndarray:
        Z = self.Vi @ R @ self.Vih
        Z /= self.denom
        solution: np.ndarray = (self.V @ Z @ self.Vh).real
        return solution


def _preconditioner(terms: Sequence[Term]) -> _SteinInverse | None:
    radii = [w * max(abs(_eig(M)[0])) ** 2 for w, M in terms]
    order = sorted(range(len(terms)), key=lambda i: -radii[i])
    for i in order:
        if radii[i] < PRECONDITIONER_MAX_RADIUS:
            P = _SteinInverse(*terms[i])
            if P.usable:
                return P
    return None


def _gmres(
    op: Callable[[np.ndarray], np.ndarray],
    pre: Callable[[np.ndarray], np.ndarray],
    b: np.ndarray,
    x: np.ndarray,
    tol: float,
    cycles: int = 0,
) -> np.ndarray:
    """Right-preconditioned restarted GMRES (Saad and Schultz 1986) for ``op(x) = b`` from ``x``.

    The Arnoldi basis is orthogonalized twice by classical Gram-Schmidt (as matrix products);
    Givens rotations keep the least-squares residual, which with right preconditioning is the
    residual of ``x`` up to rounding.  Stops when that is at most ``tol``, after ``cycles``
    (default :data:`MAX_RESTARTS`) cycles of :data:`RESTART` steps, or when a whole cycle did
    not halve the true residual ``b - op(x)``: stagnation at the accuracy that rounding allows.
    Near the mean-square threshold ``||x||`` is about ``||b|| / (1 - rho)``, and so is the
    rounding error of ``op(x)``, so a target relative to ``||b||`` cannot be met there; the
    further cycles only added rounding noise before the caller's substitute-back check.
    """
    N = b.size
    last = np.inf
    for _ in range(cycles or MAX_RESTARTS):
        r = b - op(x)
        beta = float(np.linalg.norm(r))
        if not beta > tol or not beta < 0.5 * last:  # also NaN
            return x
        last = beta
        V = np.empty((RESTART + 1, N))
        Z = np.empty((RESTART, N))
        R = np.zeros((RESTART, RESTART))  # the rotated Hessenberg matrix, upper triangular
        cs: list[float] = []
        sn: list[float] = []
        g = [beta]
        V[0] = r / beta
        k = 0
        for j in range(RESTART):
            Z[j] = pre(V[j])
            w = op(Z[j])
            h = V[: j + 1] @ w
            w -= h @ V[: j + 1]
            h2 = V[: j + 1] @ w
            w -= h2 @ V[: j + 1]
            col = (h + h2).tolist()
            sub = float(np.linalg.norm(w))
            for i in range(j):
                a, c = col[i], col[i + 1]
                col[i], col[i + 1] = cs[i] * a + sn[i] * c, -sn[i] * a + cs[i] * c
            rho = float(np.hypot(col[j], sub))
            if not rho > 0:
                break
            cs.append(col[j] / rho)
            sn.append(sub / rho)
            col[j] = rho
            g.append(-sn[j] * g[j])
            g[j] = cs[j] * g[j]
            R[: j + 1, j] = col
            k = j + 1
            if not abs(g[j + 1]) > tol or not sub > 0:
                break
            V[j + 1] = w / sub
        if k:
            y = scipy.linalg.solve_triangular(R[:k, :k], np.array(g[:k]), check_finite=False)
            x = x + y @ Z[:k]
    return x


def solve_stein(
    terms: Sequence[Term], rhs: Sequence[np.ndarray], starts: Sequence[np.ndarray | None] | None = None
) -> list[np.ndarray] | None:
    r"""``X - sum_i w_i M_i X M_i' = W`` for each ``W`` in ``rhs`` by preconditioned GMRES on ``n x n`` matrices.

    ``terms`` are the pairs ``(w_i, M_i)`` with ``w_i > 0``; GMRES starts from ``starts[k]``
    where given (a nearby equation's solution: policy iteration's previous evaluation), else from
    the preconditioner's answer.  Returns ``None`` where it declines.

    Declines (the caller then solves densely) when no term can precondition, when GMRES does not
    reach :data:`RESIDUAL_RTOL` in :data:`MAX_RESTARTS` cycles, or when the substituted-back
    residual is larger than that.
    """
    n = rhs[0].shape[0]
    P = _preconditioner(terms)
    if P is None:
        return None
    scale = 1.0 + sum(w * np.linalg.norm(M, 2) ** 2 for w, M in terms)

    def op(x: np.ndarray) -> np.ndarray:
        X = x.reshape(n, n)
        image: np.ndarray = (X - apply(terms, X)).ravel()
        return image

    def pre(x: np.ndarray) -> np.ndarray:
        return P(x.reshape(n, n)).ravel()

    out = []
    with np.errstate(all="ignore"):
        for k, W in enumerate(rhs):
            W = 0.5 * (W + W.T)
            b = W.ravel()
            x0 = starts[k] if starts is not None else None
            x0 = P(W).ravel() if x0 is None else np.array(x0, float).ravel()
            x = _gmres(op, pre, b, x0, RESIDUAL_RTOL * float(np.linalg.norm(b)))
            X = x.reshape(n, n)
            X = 0.5 * (X + X.T)
            if not np.all(np.isfinite(X)):
                return None
            res = np.linalg.norm(X - apply(terms, X) - W)
            if res > 100 * RESIDUAL_RTOL * (scale * np.linalg.norm(X) + np.linalg.norm(W)):
                return None
            out.append(X)
    return out


def solve_near(
    terms: Sequence[Term], factor: tuple[np.ndarray, np.ndarray], rhs: np.ndarray, start: np.ndarray
) -> np.ndarray | None:
    r"""``vech`` of the solution of ``X - sum_i w_i M_i X M_i' = W`` (``rhs = vech(W)``), preconditioned by a nearby operator.

    ``factor`` is ``scipy.linalg.lu_factor`` of the ``vech`` matrix of a nearby operator
    ``I - L'`` (the same ``M_i``, other weights): the continuation's stability test at the
    next point of its bisection.  The preconditioned operator ``(I - L')^-1 (I - L)`` is the
    identity plus a multiple of the weights' change, so GMRES needs a few steps (one cycle
    of :data:`RESTART` at most, else ``None`` and the caller factors afresh).  ``start`` is
    the first guess.  The substituted-back residual is checked as in :func:`solve_stein`.
    """
    n = int(round((np.sqrt(8 * rhs.size + 1) - 1) / 2))
    iu, ju, _ = vech_layout(n)
    scale = 1.0 + sum(w * np.linalg.norm(M, 2) ** 2 for w, M in terms)

    def op(h: np.ndarray) -> np.ndarray:
        X = unvech(h, n)
        values_out: np.ndarray = h - (apply(terms, X))[iu, ju]
        return values_out

    def pre(h: np.ndarray) -> np.ndarray:
        arr: np.ndarray = scipy.linalg.lu_solve(factor, h, check_finite=False)
        return arr

    tol = RESIDUAL_RTOL * float(np.linalg.norm(rhs))
    with np.errstate(all="ignore"):
        h = _gmres(op, pre, rhs, start, tol, cycles=1)
        if not np.all(np.isfinite(h)):
            return None
        X = unvech(h, n)
        res = np.linalg.norm(X - apply(terms, X) - unvech(rhs, n))
        if res > 100 * RESIDUAL_RTOL * (scale * np.linalg.norm(X) + np.linalg.norm(unvech(rhs, n))):
            return None
    return h
