r"""Where a one-parameter family of positive operators crosses ``rho = 1``: the continuation's threshold.

The continuation of :meth:`kfio.riccati_bounds._search.CertifiedSearch._slide` keeps gains
``K`` fixed and asks, along one arrival probability ``x``, where

.. math::

    \mathcal L_x(X) = \sum_i w_i(x)\, M_i X M_i', \qquad \rho(\mathcal L_x) < 1,

starts to hold (``M_0 = A``, ``M_S = A + K_S C_S``; the pattern weights ``w_i`` are affine in
``x``; Sinopoli et al. (2004), Lemma 3; Liu and Goldsmith (2004), eq. 16).  Its bisection asks
a linear solve at some twenty points.  Every decision far from the threshold is already fixed
by where ``rho(L_x)`` crosses 1, so that crossing is found first, from the spectral radius alone:

* ``L_x`` is completely positive, so its spectral radius is an eigenvalue with a positive
  semidefinite eigenvector (the Perron root; Evans and Hoegh-Krohn 1978), and it is the
  largest eigenvalue in modulus.  ARPACK's implicitly restarted Arnoldi method (Lehoucq,
  Sorensen and Yang 1998, through ``scipy.sparse.linalg.eigs``) finds it from operator
  applications alone, two ``n x n`` products per term (``O(n^3)``), never forming the
  ``n^2 x n^2`` matrix;
* Brent's method (Brent 1973, ``scipy.optimize.brentq``) finds the ``x`` where
  ``rho(L_x) - 1`` changes sign;
* the crossing ``t`` is then confirmed at ``t - m`` and ``t + m``, where ``rho - 1`` must be
  at least :data:`CLEAR` away from 0 on the right side.

The result is only a guide: the bisection asks its own stability test at every point within
``m`` of ``t`` and uses the crossing for the points farther away, where ``|rho - 1|`` is far
above that test's rounding.  When the spectral radius is not monotone across the confirmed
points, or anything fails to converge, :func:`crossing` returns ``None`` and the bisection asks
its own test everywhere, as before.  Either way the point the bisection returns is then
re-checked exactly by the certificate.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
import scipy.optimize
import scipy.sparse.linalg

#: ``|rho - 1|`` that the confirmation at ``t -/+ m`` asks for: far above the bisection's own rounding.
CLEAR = 1e-8
#: The half-widths ``m`` tried around the crossing, smallest first.
MARGINS = (4e-8, 4e-7, 4e-6)
#: ARPACK's relative accuracy for the Ritz value, and its Krylov dimension.
EIGS_TOL, EIGS_NCV = 1e-14, 20
#: Brent's tolerance on ``x``: far below the smallest margin.
XTOL = 1e-11
#: Relative size of an imaginary part, or of a negative eigenvalue of the eigenvector, still taken as rounding.
PSD_TOL = 1e-8
#: Up to this dimension of ``vec`` the spectrum is computed densely (ARPACK needs room for its basis).
DENSE_DIM = 64

Term = tuple[float, np.ndarray]


@dataclass(frozen=True)
class Crossing:
    """Below ``unstable_at_most`` the operator is unstable, above ``stable_from`` stable; in between: ask.

    Attributes
    ----------
    unstable_at_most, stable_from:
        The confirmed points ``t - m`` and ``t + m`` (or ``lo`` and ``lo + m`` when
        ``rho(L_lo) <= 1`` already).
    evaluations:
        Spectral radii computed.
    """

    unstable_at_most: float
    stable_from: float
    evaluations: int

    def decide(self, x: float) -> bool | None:
        """``True`` (stable), ``False`` (unstable), or ``None``: too close, ask the solver."""
        if x >= self.stable_from:
            return True
        if x <= self.unstable_at_most:
            return False
        return None


class PerronRadius:
    """``rho(L) = max |eig(L)|`` for ``L(X) = sum_i w_i M_i X M_i'``, each start from the last eigenvector."""

    def __init__(self, matrices: Sequence[np.ndarray]) -> None:
        self.M = [np.asarray(M, float) for M in matrices]
        self.Mt = [M.T.copy() for M in self.M]
        self.n = self.M[0].shape[0]
        self.v = np.eye(self.n).ravel()  # a positive definite start: it has a component along the Perron vector
        self.evaluations = 0

    def __call__(self, weights: Sequence[float]) -> float:
        """The spectral radius at ``weights``; raises ``ArithmeticError`` when it cannot be trusted."""
        self.evaluations += 1
        n = self.n
        active = [(float(w), M, Mt) for w, M, Mt in zip(weights, self.M, self.Mt) if w > 0]
        if not active:
            return 0.0
        if len(active) == 1:  # one congruence: its eigenvalues are w theta_i theta_j, so rho = w rho(M)^2
            return active[0][0] * float(np.max(np.abs(np.linalg.eigvals(active[0][1])))) ** 2
        if n * n <= DENSE_DIM:
            L = sum(w * np.kron(M, M) for w, M, _ in active)
            return float(np.max(np.abs(np.linalg.eigvals(L))))

        def matvec(h: np.ndarray) -> np.ndarray:
            X = h.reshape(n, n)
            out = active[0][0] * (active[0][1] @ X @ active[0][2])
            for w, M, Mt in active[1:]:
                out += w * (M @ X @ Mt)
            return out.ravel()

        op = scipy.sparse.linalg.LinearOperator((n * n, n * n), matvec=matvec, dtype=float)
        # the last Perron vector plus I / sqrt(n): positive definite, so it has a positive component
        # <U, v0> along every positive semidefinite left eigenvector U, the Perron one included
        v0 = self.v + np.eye(n).ravel() / np.sqrt(n)
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


def crossing(
    weights_at: Callable[[float], Sequence[float]], matrices: Sequence[np.ndarray], lo: float, hi: float
) -> Crossing | None:
    r"""Where ``rho(sum_i w_i(x) M_i . M_i')`` crosses 1 on ``[lo, hi]``, confirmed on both sides; ``None`` if not found.

    ``rho`` must be below ``1 - CLEAR`` at ``hi``.  If it is at most ``1 + CLEAR`` at ``lo``,
    the operator is taken as stable from ``lo + m`` on (confirmed there); else Brent's method
    finds the crossing ``t`` to :data:`XTOL` and ``rho - 1`` is confirmed beyond
    ``CLEAR`` at ``t -/+ m``, for the smallest ``m`` of :data:`MARGINS` where it is.
    """
    rho = PerronRadius(matrices)

    def f(x: float) -> float:
        return rho(weights_at(x)) - 1.0

    try:
        with np.errstate(all="ignore"):
            if not f(hi) < -CLEAR:
                return None
            f_lo = f(lo)
            if not np.isfinite(f_lo):
                return None
            if f_lo <= CLEAR:
                for m in MARGINS:
                    if lo + m < hi and f(lo + m) < -CLEAR:
                        return Crossing(lo, lo + m, rho.evaluations)
                return None
            t = float(scipy.optimize.brentq(f, lo, hi, xtol=XTOL))
            for m in MARGINS:
                if lo < t - m and t + m < hi and f(t - m) > CLEAR and f(t + m) < -CLEAR:
                    return Crossing(t - m, t + m, rho.evaluations)
    except (ArithmeticError, ValueError, RuntimeError):
        return None
    return None
