r"""Where a one-parameter family of positive operators crosses ``rho = 1``: a guide for the continuation's bisection.

The continuation of :meth:`kfio.riccati_bounds._search.CertifiedSearch._slide` keeps gains
``K`` fixed and asks, along one arrival probability ``x``, where

.. math::

    \mathcal L_x(X) = \sum_i w_i(x)\, M_i X M_i', \qquad \rho(\mathcal L_x) < 1,

starts to hold (``M_0 = A``, ``M_S = A + K_S C_S``; the pattern weights ``w_i`` are affine in
``x``; Sinopoli et al. (2004), Lemma 3; Liu and Goldsmith (2004), eq. 16).  Its bisection
solves ``Y - L_x(Y) = I`` at some twenty points.  When stability is monotone in ``x`` (the
assumption the bisection makes), every one of its decisions follows from where ``rho(L_x)``
crosses 1, so that crossing is estimated first, from the spectral radius alone:

* ``L_x`` is completely positive, so its spectral radius is an eigenvalue with a positive
  semidefinite eigenvector (the Perron root; Evans and Hoegh-Krohn 1978), and it is the
  largest eigenvalue in modulus.  ARPACK's implicitly restarted Arnoldi method (Lehoucq,
  Sorensen and Yang 1998, through ``scipy.sparse.linalg.eigs``) finds it from operator
  applications alone, two ``n x n`` products per term (``O(n^3)``), never forming the
  ``n^2 x n^2`` matrix;
* the secant method on ``rho(L_x) - 1``, kept inside the bracket that its own evaluations
  establish, finds the crossing.

The estimate is only a guide: the bisection replays its steps with it and then asks its own
stability test at the two ends it arrived at.  When the test agrees there, monotonicity gives
the same answer at every earlier step, so the bisection ends where it would have ended with a
solve at every point; when not, the bisection runs again with a solve at every point.  Either
way the point it returns is then re-checked exactly by the certificate.
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np
import scipy.sparse.linalg

from ._stein import apply

#: ARPACK's relative accuracy for the Ritz value, and its Krylov dimension.
EIGS_TOL, EIGS_NCV = 1e-10, 20
#: The secant method stops when its step or its bracket is below this.
XTOL = 1e-10
#: Secant steps allowed.
MAX_STEPS = 40
#: Relative size of an imaginary part, or of a negative eigenvalue of the eigenvector, still taken as rounding.
PSD_TOL = 1e-6
#: Up to this dimension of ``vec`` the spectrum is computed densely (ARPACK needs room for its basis).
DENSE_DIM = 64

Term = tuple[float, np.ndarray]


class PerronRadius:
    """``rho(L) = max |eig(L)|`` for ``L(X) = sum_i w_i M_i X M_i'``, each start from the last eigenvector."""

    def __init__(self, matrices: Sequence[np.ndarray]) -> None:
        self.M = [np.asarray(M, float) for M in matrices]
        self.n = self.M[0].shape[0]
        self.v = np.eye(self.n).ravel()  # a positive definite start: it has a component along the Perron vector
        self.evaluations = 0

    def __call__(self, weights: Sequence[float]) -> float:
        """The spectral radius at ``weights``; raises ``ArithmeticError`` when it cannot be trusted."""
        self.evaluations += 1
        n = self.n
        active = [(float(w), M) for w, M in zip(weights, self.M) if w > 0]
        if not active:
            return 0.0
        if len(active) == 1:  # one congruence: its eigenvalues are w theta_i theta_j, so rho = w rho(M)^2
            return active[0][0] * float(np.max(np.abs(np.linalg.eigvals(active[0][1])))) ** 2
        if n * n <= DENSE_DIM:
            L = sum(w * np.kron(M, M) for w, M in active)
            return float(np.max(np.abs(np.linalg.eigvals(L))))

        def matvec(h: np.ndarray) -> np.ndarray:
            return apply(active, h.reshape(n, n)).ravel()

        op = scipy.sparse.linalg.LinearOperator((n * n, n * n), matvec=matvec, dtype=float)
        # from I (positive definite: it has a positive component <U, I> along the Perron left eigenvector U),
        # then from the last Perron vector (a nearby operator's)
        v0 = self.v
        try:
            vals, vecs = scipy.sparse.linalg.eigs(op, k=1, which="LM", v0=v0, tol=EIGS_TOL, ncv=EIGS_NCV)
        except scipy.sparse.linalg.ArpackError as e:  # includes ArpackNoConvergence
            raise ArithmeticError(str(e)) from e
        r, v = vals[0], vecs[:, 0]
        if not (np.isfinite(r) and abs(r.imag) <= PSD_TOL * abs(r) and r.real > 0):
            raise ArithmeticError("the eigenvalue of largest modulus is not the Perron root")
        v = v.real if np.linalg.norm(v.real) >= np.linalg.norm(v.imag) else v.imag
        V = v.reshape(n, n)
        d = np.linalg.eigvalsh(0.5 * (V + V.T))
        if d[-1] < -d[0]:
            v, d = -v, -d[::-1]
        if not (np.all(np.isfinite(d)) and d[-1] > 0 and d[0] >= -PSD_TOL * d[-1]):
            raise ArithmeticError("the eigenvector of largest modulus is not semidefinite")
        self.v = v / np.linalg.norm(v)
        return float(r.real)

    def rayleigh(self, weights: Sequence[float]) -> float:
        """``<V, L(V)> / <V, V>`` for the last Perron vector ``V`` and any real ``weights``: a derivative's guess."""
        V = self.v.reshape(self.n, self.n)
        LV = apply([(float(w), M) for w, M in zip(weights, self.M) if w != 0], V)
        return float(np.sum(V * LV) / np.sum(V * V))


def estimate_crossing(
    weights_at: Callable[[float], Sequence[float]], matrices: Sequence[np.ndarray], lo: float, hi: float
) -> float | None:
    r"""An estimate of the ``x`` in ``(lo, hi)`` where ``rho(sum_i w_i(x) M_i . M_i')`` crosses 1, or ``None``.

    The secant method on ``f(x) = rho - 1`` from ``hi`` and a Newton step from there (the slope
    guessed by :meth:`PerronRadius.rayleigh`; the midpoint if that leaves ``(lo, hi)``); a step that leaves
    the bracket ``a < x < b`` known so far (``f(a) > 0 > f(b)``) is replaced by regula falsi
    or by the bracket's midpoint.  ``lo`` itself when ``f(lo) <= 0``.  ``None`` when
    ``f(hi) >= 0``, when a spectral radius cannot be trusted (:class:`PerronRadius`), or after
    :data:`MAX_STEPS` steps.
    """
    rho = PerronRadius(matrices)

    def f(x: float) -> float:
        return rho(weights_at(x)) - 1.0

    try:
        with np.errstate(all="ignore"):
            a, fa = lo, float("nan")  # f(a) > 0 once evaluated
            b, fb = hi, f(hi)
            if not fb < 0:
                return None
            x0, f0 = b, fb
            # a Newton step with the slope <V, L'(V)> / <V, V> at hi (V its Perron vector), else the midpoint
            x1 = 0.5 * (lo + hi)
            if len(matrices) > 1:
                w_hi, w_lo = weights_at(hi), weights_at(lo)
                slope = rho.rayleigh([(p - q) / (hi - lo) for p, q in zip(w_hi, w_lo)])
                newton = hi - fb / slope if slope < 0 else np.nan
                if lo < newton < hi:
                    x1 = newton
            f1 = f(x1)
            for _ in range(MAX_STEPS):
                if f1 > 0:
                    a, fa = x1, f1
                else:
                    b, fb = x1, f1
                if b - a <= XTOL:
                    return x1
                x2 = x1 - f1 * (x1 - x0) / (f1 - f0) if f1 != f0 else np.nan
                if not a < x2 < b and not np.isfinite(fa):  # the step leaves the bracket: is lo itself stable?
                    fa = f(a)
                    if not fa > 0:
                        return lo if fa <= 0 else None  # stable down to lo, or NaN
                if not a < x2 < b:
                    x2 = a - fa * (b - a) / (fb - fa)  # regula falsi
                    if not a < x2 < b:
                        x2 = 0.5 * (a + b)
                step = abs(x2 - x1)
                x0, f0 = x1, f1
                x1 = x2
                f1 = f(x1)
                if not np.isfinite(f1):
                    return None
                if step <= XTOL:
                    return x1
    except (ArithmeticError, ValueError):
        return None
    return None
