"""Where the stability LMI is feasible: bisection for ``lambda_upper`` and the region map.

Seed 004's ``lambda_upper`` is the infimum of the ``lambda`` where the LMI of
Theorem 5 is feasible (Corollary 1: bisection over LMI feasibility problems);
seed 000 does the same for one packet's probability with the others fixed
(Theorem 3) and draws the stable region of two packets (Figs. 4-5).
Feasibility is monotone in every arrival probability (seed 004 Lemma 1(d),
seed 000 Lemma 3: ``X > g(X)`` at ``lambda`` implies it at every larger
``lambda``), which is what makes bisection and the region's shortcuts valid.

Scaling matters (MATH.md section 3): near the threshold every feasible ``X``
is badly conditioned (its component along the unstable mode blows up like
``1 / (lambda - lambda_c)``), and the LMI margin in ``Y = X^-1`` shrinks like
the *square* of the distance to the threshold, below the solver's tolerance.
So the LMI is solved in working coordinates ``x~ = T x``: first ``T = D^-1``
from balancing ``A``, then, after every certified point, the coordinates in
which that point's certificate ``X`` is the identity (``T X T' = I``).  The
next, nearby bisection point then has a well-conditioned certificate and
its margin shrinks only linearly.  Every answer is re-checked in the user's
coordinates (:mod:`kfio.mare._certificate`), so ``T`` affects speed and
reach, never soundness.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Callable, Sequence

import numpy as np

from .._budget import Budget
from ._certificate import ExactPlant, StabilityCertificate, certify
from ._lmi import StabilityLMI, balancing_scaling
from ._riccati import ArrivalModel, closed_loop_operator, pattern_weights, subset_rows

#: Bisection points are rounded to this grid so that exact values print as short decimals.
GRID = Fraction(1, 10**12)


@dataclass(frozen=True)
class UpperBound:
    """Result of a bisection for the smallest certified arrival probability.

    Attributes
    ----------
    value:
        A probability at which a certificate was re-checked, or ``None``.
    certificate:
        That certificate.
    lower_end:
        The largest probability at which no certificate was found (the
        solver's infeasibility is *not* certified): the infimum lies in
        ``(lower_end - 0, value]`` up to the solver's reliability.
    steps:
        LMI solves used.
    reason:
        Why ``value`` is ``None``.
    """

    value: Fraction | None
    certificate: StabilityCertificate | None
    lower_end: Fraction | None
    steps: int
    reason: str | None = None


class CertifiedSearch:
    """LMI feasibility at exact arrival probabilities, every positive answer re-checked.

    Parameters
    ----------
    A, C:
        Float plant matrices.
    row_groups:
        Rows of ``C`` carried by each packet.
    plant:
        The exact ``A`` and ``C_S`` for :func:`kfio.mare._certificate.exact_check`.
    budget:
        Ticked once per LMI solve.
    exact:
        Re-check exactly (default) or by eigenvalues only.
    recenter:
        Re-center the working coordinates on each certificate (default);
        ``False`` keeps the balanced coordinates (the naive formulation).
    """

    def __init__(
        self,
        A: np.ndarray,
        C: np.ndarray,
        row_groups: Sequence[Sequence[int]],
        plant: ExactPlant,
        budget: Budget | None = None,
        exact: bool = True,
        recenter: bool = True,
    ) -> None:
        self.A = np.asarray(A, float)
        rows = subset_rows(row_groups)
        self.C_S = tuple(np.asarray(C, float)[r, :] for r in rows)
        self.plant = plant
        self.budget = budget
        self.exact = exact
        self.recenter = recenter
        n = self.A.shape[0]
        self.lmi = StabilityLMI(n, [len(r) for r in rows])
        self._T = np.diag(1.0 / balancing_scaling(self.A))  # x~ = D^-1 x: balanced first, then recentred
        self.solves = 0

    def _model(self, weights: Sequence[float]) -> ArrivalModel:
        n = self.A.shape[0]
        zero = np.zeros((n, n))
        return ArrivalModel(
            self.A, zero, self.C_S, tuple(np.zeros((c.shape[0],) * 2) for c in self.C_S), tuple(weights)
        )

    def certify(self, lambdas: Sequence[Fraction]) -> StabilityCertificate | None:
        """Solve the LMI at ``lambdas`` and re-check its gains; a certificate or ``None``."""
        if self.budget is not None:
            self.budget.tick("stability LMI", 1)
        self.solves += 1
        weights = [float(w) for w in pattern_weights([Fraction(x) for x in lambdas])]
        T = self._T
        Ti = np.linalg.inv(T)
        sol = self.lmi.solve(T @ self.A @ Ti, [C @ Ti for C in self.C_S], weights)
        K_work = sol.gains()
        if K_work is None:
            return None
        return self.check_gains(lambdas, tuple(Ti @ k for k in K_work), sol.margin)  # T(A + K C)T^-1 = A~ + (T K) C~

    def check_gains(
        self, lambdas: Sequence[Fraction], K: Sequence[np.ndarray], solver_margin: float | None = None
    ) -> StabilityCertificate | None:
        """Re-check gains ``K`` (user coordinates) at ``lambdas`` without solving anything."""
        exact_w = pattern_weights([Fraction(x) for x in lambdas])
        model = self._model([float(w) for w in exact_w])
        cert = certify(model, self.plant, lambdas, exact_w, K, solver_margin, self.exact)
        if cert is not None and self.recenter:
            self._recenter(cert.X)
        return cert

    def _slide(
        self,
        at: Callable[[Fraction], list[Fraction]],
        lo: Fraction,
        hi: Fraction,
        K: Sequence[np.ndarray],
        tol: Fraction,
    ) -> tuple[Fraction, StabilityCertificate] | None:
        """Lower ``hi`` for free: the smallest point of ``(lo, hi)`` where the same gains ``K`` still certify.

        A float bisection on ``rho(L_K) < 1`` along the coordinate (no LMI
        solve), then one exact re-check there.  With a single unstable mode
        the gains that zero it work all the way down to the lower bound
        (seed 004 Sec. IV), so one solve near the threshold finishes the search.
        """

        def stable(x: float) -> bool:
            weights = [float(w) for w in pattern_weights(at(Fraction(x)))]
            L = closed_loop_operator(self._model(weights), K)
            return bool(np.max(np.abs(np.linalg.eigvals(L))) < 1.0)

        a, b = float(lo), float(hi)
        while b - a > float(tol) / 4:
            c = 0.5 * (a + b)
            a, b = (a, c) if stable(c) else (c, b)
        x = Fraction(math.ceil(Fraction(b) / GRID)) * GRID
        if not lo < x < hi - tol / 2:
            return None
        cert = self.check_gains(at(x), K)
        return None if cert is None else (x, cert)

    def _recenter(self, X: np.ndarray) -> None:
        try:
            L = np.linalg.cholesky(X / np.linalg.norm(X, 2))
        except np.linalg.LinAlgError:
            return
        self._T = np.linalg.inv(L)

    def bisect(self, base: Sequence[Fraction], coordinate: int, lower: float, tolerance: float) -> UpperBound:
        """Smallest certified value of ``lambdas[coordinate]``, the others fixed at ``base``.

        Starts from 1 (must be certified, else no upper bound exists within
        the model) and bisects down towards ``lower`` (a value where the LMI
        is known to be infeasible, e.g. the closed-form lower bound) until
        the bracket is shorter than ``tolerance``.
        """
        pts = list(base)

        def at(x: Fraction) -> list[Fraction]:
            pts[coordinate] = x
            return list(pts)

        steps0 = self.solves
        hi = Fraction(1)
        cert = self.certify(at(hi))
        if cert is None:
            return UpperBound(None, None, hi, self.solves - steps0, "no certificate even at arrival probability 1")
        lo = max(Fraction(0), Fraction(lower)) if lower > 0 else None
        if lo is None:  # the lower bound is vacuous: try 0 itself
            cert0 = self.certify(at(Fraction(0)))
            if cert0 is not None:
                return UpperBound(Fraction(0), cert0, None, self.solves - steps0)
            lo = Fraction(0)
        tol = Fraction(tolerance)
        while hi - lo > tol:
            slid = self._slide(at, lo, hi, cert.K, tol)
            if slid is not None:
                hi, cert = slid
                if hi - lo <= tol:
                    break
            mid = ((lo + hi) / 2 / GRID).__round__() * GRID
            if not lo < mid < hi:
                break
            c = self.certify(at(mid))
            if c is not None:
                hi, cert = mid, c
            else:
                lo = mid
        return UpperBound(hi, cert, lo, self.solves - steps0)

    def region(self, values: Sequence[Fraction], unstable: np.ndarray) -> tuple[list[list[str]], int]:
        """Label the grid ``values x values`` for two packets: stable / unstable / undecided.

        ``unstable[i, j]`` marks the cells the lower bound proves unstable.
        Stable cells form an up-set (seed 000, Lemma 3), so each column
        ``lambda_1 = values[i]`` needs a binary search for its lowest
        certified cell, and that cell bounds the search of the next column.
        Returns the labels (``labels[i][j]`` for ``(values[i], values[j])``)
        and the number of certified cells that support them.
        """
        K = len(values)
        labels = [["unstable" if unstable[i, j] else "undecided" for j in range(K)] for i in range(K)]
        lowest_prev: int | None = None  # lowest stable index of the previous column
        certified = 0
        for i in range(K):
            free = [j for j in range(K) if not unstable[i, j]]
            if not free:
                continue
            lo_idx = free[0] - 1  # everything <= lo_idx is not certified
            if lowest_prev is not None:
                hi_idx = lowest_prev  # stable by monotonicity in lambda_1
            else:
                if self.certify([values[i], values[K - 1]]) is None:
                    continue
                certified += 1
                hi_idx = K - 1
            while hi_idx - lo_idx > 1:
                mid = (lo_idx + hi_idx) // 2
                if self.certify([values[i], values[mid]]) is not None:
                    hi_idx = mid
                    certified += 1
                else:
                    lo_idx = mid
            for j in range(hi_idx, K):
                labels[i][j] = "stable"
            lowest_prev = hi_idx
        return labels, certified
