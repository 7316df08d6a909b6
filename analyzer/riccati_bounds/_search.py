"""Where the stability LMI is feasible: bisection for ``lambda_upper`` and the region map.

Sinopoli et al. (2004)'s ``lambda_upper`` is the infimum of the ``lambda`` where the LMI of
Theorem 5 is feasible (Corollary 1: bisection over LMI feasibility problems);
Liu and Goldsmith (2004) does the same for one packet's probability with the others fixed
(Theorem 3) and draws the stable region of two packets (Figs. 4-5).
Feasibility is monotone in every arrival probability (Sinopoli et al. (2004) Lemma 1(d),
Liu and Goldsmith (2004) Lemma 3: ``X > g(X)`` at ``lambda`` implies it at every larger
``lambda``), which is what makes bisection and the region's shortcuts valid.

Scaling matters (docs/theory.md): near the threshold every feasible ``X``
is badly conditioned (its component along the unstable mode blows up like
``1 / (lambda - lambda_c)``), and the LMI margin in ``Y = X^-1`` shrinks like
the *square* of the distance to the threshold, below the solver's tolerance.
So the LMI is solved in working coordinates ``x~ = T x``: first ``T = D^-1``
from balancing ``A``, then, after every certified point, the coordinates in
which that point's certificate ``X`` is the identity (``T X T' = I``).  The
next, nearby bisection point then has a well-conditioned certificate and
its margin shrinks only linearly.  Every answer is re-checked in the user's
coordinates (:mod:`kfio.riccati_bounds._certificate`), so ``T`` affects speed and
reach, never soundness.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Callable, Sequence

import numpy as np
import scipy.linalg

from .._budget import Budget
from ._certificate import ExactPlant, StabilityCertificate, certify
from ._gains import annihilating_gains, normalized_model, policy_gains
from ._lmi import StabilityLMI, balancing_scaling
from ._perron import estimate_crossing
from ._riccati import ArrivalModel, float_pattern_weights, gains, pattern_weights, solve_v_bar, subset_rows
from ._small_linalg import cholesky_succeeds, solve_finite
from ._stein import DENSE_MAX_N, solve_near
from ._vech import congruence_matrix, unvech, vech

#: Bisection points are rounded to this grid so that exact values print as short decimals.
GRID = Fraction(1, 10**12)
#: Steps of the MARE iteration from 0 before its gains are given up at a point (Newton takes over at 16, 32, ...).
MARE_MAX_ITER = 4096
#: Largest ``n`` at which the probe below the continuation's end also solves the LMI (about 0.1 s at n = 10;
#: seconds from n = 20 on, where the continuation's stall is the evidence, see :meth:`CertifiedSearch.bisect`).
LMI_PROBE_MAX_N = 12
#: Slide / re-optimize rounds of the continuation in :meth:`CertifiedSearch.bisect`.
MAX_ROUNDS = 64
#: Above this many states the slide's bisection is first replayed with an estimate of where ``rho(L_K)``
#: crosses 1 (:func:`kfio.riccati_bounds._perron.estimate_crossing`); the solver is asked at its two ends only.
PERRON_MIN_N = 24


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
        The largest probability at which no certificate was found: "not
        certified" there, which is *not* a proof of infeasibility (neither
        the solver's nor a diverging float iteration is one).  Only the
        closed-form lower bound is proved.
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
    """Certificates at exact arrival probabilities: solver-free gains first, the LMI where they fail.

    Every positive answer is re-checked (:func:`kfio.riccati_bounds._certificate.certify`,
    Sinopoli et al. (2004) Theorem 5(b) over the rationals), whichever route produced the
    gains: the annihilating gains and the MARE's optimal gains refined by
    policy iteration (:mod:`kfio.riccati_bounds._gains`), then the LMI of Theorem 5(c).

    Parameters
    ----------
    A, C:
        Float plant matrices.
    row_groups:
        Rows of ``C`` carried by each packet.
    plant:
        The exact ``A`` and ``C_S`` for :func:`kfio.riccati_bounds._certificate.exact_check`.
    budget:
        Ticked once per LMI solve and per policy-iteration or slide step.
    exact:
        Re-check exactly (default) or by eigenvalues only.
    recenter:
        Re-center the LMI's working coordinates on each certificate (default);
        ``False`` keeps the balanced coordinates (the naive formulation).
    lmi:
        ``"fallback"`` (default): solve the LMI only where the solver-free
        gains do not certify; ``"always"``: the LMI at every point
        (the reference route of the benchmark); ``"never"``: no solver.
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
        lmi: str = "fallback",
    ) -> None:
        if lmi not in ("fallback", "always", "never"):
            raise ValueError(f"lmi must be 'fallback', 'always' or 'never', not {lmi!r}")
        self.A = np.asarray(A, float)
        rows = subset_rows(row_groups)
        self.C_S = tuple(np.asarray(C, float)[r, :] for r in rows)
        self.plant = plant
        self.budget = budget
        self.exact = exact
        self.recenter = recenter
        self.lmi_mode = lmi
        self._pattern_rows = [len(r) for r in rows]
        self._lmi: StabilityLMI | None = None  # built on first use: CVXPY compilation costs at large n
        D = balancing_scaling(self.A)
        self._T0 = np.diag(1.0 / D)  # x~ = D^-1 x: the balanced coordinates of the solver-free route
        self._T0i = np.diag(D)
        self._T = self._T0.copy()  # the LMI's working coordinates: balanced first, then recentred
        self._annihilating: tuple[np.ndarray, ...] | None | bool = False  # False: not computed yet
        self.solves = 0
        self.routes: dict[str, int] = {}  # certificates found, by route
        self.perron = True  # the slide's bisection guided by the Perron root (False: a solve at every point)
        self.guided = 0  # slides whose bisection the Perron root guided

    @property
    def lmi(self) -> StabilityLMI:
        if self._lmi is None:
            self._lmi = StabilityLMI(self.A.shape[0], self._pattern_rows)
        return self._lmi

    @lmi.setter
    def lmi(self, value: StabilityLMI) -> None:
        self._lmi = value

    def _tick(self, what: str) -> None:
        if self.budget is not None:
            self.budget.tick(what)

    def _model(self, weights: Sequence[float]) -> ArrivalModel:
        n = self.A.shape[0]
        zero = np.zeros((n, n))
        return ArrivalModel(
            self.A, zero, self.C_S, tuple(np.zeros((c.shape[0],) * 2) for c in self.C_S), tuple(weights)
        )

    @staticmethod
    def _float_weights(lambdas: Sequence[Fraction]) -> list[float]:
        return float_pattern_weights(lambdas)  # the floats of the exact weights, in integer arithmetic

    def _working_model(self, lambdas: Sequence[Fraction]) -> ArrivalModel:
        T, Ti = self._T0, self._T0i
        return normalized_model(T @ self.A @ Ti, [C @ Ti for C in self.C_S], self._float_weights(lambdas))

    def annihilating(self) -> tuple[np.ndarray, ...] | None:
        """The gains of :func:`kfio.riccati_bounds._gains.annihilating_gains` (user coordinates), computed once."""
        if self._annihilating is False:
            self._annihilating = annihilating_gains(self.A, self.C_S)
        return self._annihilating  # type: ignore[return-value]

    def refine(self, lambdas: Sequence[Fraction], K: Sequence[np.ndarray]) -> tuple[np.ndarray, ...] | None:
        """Policy iteration at ``lambdas`` from gains ``K`` (user coordinates); ``None`` if ``K`` does not stabilize."""
        self._tick("policy iteration")
        T, Ti = self._T0, self._T0i
        K_work = policy_gains(self._working_model(lambdas), [T @ k for k in K])
        return None if K_work is None else tuple(Ti @ k for k in K_work)

    def mare_gains(self, lambdas: Sequence[Fraction]) -> tuple[tuple[np.ndarray, ...] | None, bool]:
        """The optimal gains of ``V_bar`` (``Q = I``, ``R = I``) by :func:`solve_v_bar` from 0.

        Returns the gains (user coordinates) or ``None``, and whether the
        iteration diverged (a float observation, not a proof).
        """
        model = self._working_model(lambdas)
        it = solve_v_bar(model, max_iter=MARE_MAX_ITER, budget=self.budget)
        if it.matrix is None:
            return None, it.iterations < MARE_MAX_ITER  # stopped early: the trace exploded
        Ti = self._T0i
        return tuple(Ti @ k for k in gains(it.matrix, model)), False

    def certify(
        self,
        lambdas: Sequence[Fraction],
        prior: Sequence[np.ndarray] | None = None,
        scratch: bool = True,
        lmi: bool = True,
    ) -> StabilityCertificate | None:
        """A re-checked certificate at ``lambdas``, or ``None``.

        Tries, in order: the annihilating gains; the policy-iteration
        refinement of ``prior`` (gains certified nearby); with ``scratch``,
        the MARE's gains from 0; with ``lmi``, the LMI (per
        :attr:`lmi_mode`; not where the MARE iteration diverged, since by
        Sinopoli et al. (2004) Theorem 5 the LMI is then infeasible too, up to rounding).
        """
        if self.lmi_mode == "always":
            return self.certify_lmi(lambdas)
        K0 = self.annihilating()
        if K0 is not None:
            cert = self.check_gains(lambdas, K0, route="annihilating gains")
            if cert is not None:
                return cert
        if prior is not None:
            K1 = self.refine(lambdas, prior)
            if K1 is not None:
                cert = self.check_gains(lambdas, K1, route="MARE gains by policy iteration")
                if cert is not None:
                    return cert
        diverged = False
        if scratch:
            K2, diverged = self.mare_gains(lambdas)
            if K2 is not None:
                cert = self.check_gains(lambdas, K2, route="MARE gains by policy iteration")
                if cert is not None:
                    return cert
        if not lmi or self.lmi_mode == "never" or diverged:
            return None
        return self.certify_lmi(lambdas)

    def certify_lmi(self, lambdas: Sequence[Fraction]) -> StabilityCertificate | None:
        """Solve the LMI at ``lambdas`` and re-check its gains; a certificate or ``None``."""
        if self.budget is not None:
            self.budget.tick("stability LMI", 1)
        self.solves += 1
        weights = self._float_weights(lambdas)
        T = self._T
        Ti = np.linalg.inv(T)
        sol = self.lmi.solve(T @ self.A @ Ti, [C @ Ti for C in self.C_S], weights)
        K_work = sol.gains()
        if K_work is None:
            return None
        # T(A + K C)T^-1 = A~ + (T K) C~
        return self.check_gains(lambdas, tuple(Ti @ k for k in K_work), sol.margin, route="LMI")

    def check_gains(
        self,
        lambdas: Sequence[Fraction],
        K: Sequence[np.ndarray],
        solver_margin: float | None = None,
        route: str = "LMI",
        near: Sequence[Any] | None = None,
    ) -> StabilityCertificate | None:
        """Re-check gains ``K`` (user coordinates) at ``lambdas`` without solving anything.

        ``near``: a nearby operator's LU factors and solution, for
        :func:`kfio.riccati_bounds._certificate.lyapunov_certificate`.
        """
        exact_w = pattern_weights([Fraction(x) for x in lambdas])
        model = self._model([float(w) for w in exact_w])
        cert = certify(model, self.plant, lambdas, exact_w, K, solver_margin, self.exact, route, near)
        if cert is not None:
            self.routes[route] = self.routes.get(route, 0) + 1
            if self.recenter:
                self._recenter(cert.X)
        return cert

    def _slide(
        self,
        at: Callable[[Fraction], list[Fraction]],
        lo: Fraction,
        hi: Fraction,
        K: Sequence[np.ndarray],
        tol: Fraction,
        route: str,
    ) -> tuple[Fraction, StabilityCertificate] | None:
        """Lower ``hi`` for free: the smallest point of ``(lo, hi)`` where the same gains ``K`` still certify.

        A float bisection on ``rho(L_K) < 1`` along the coordinate (no LMI
        solve), then one exact re-check there.  ``rho(L_K) < 1`` is tested by
        solving ``Y - L_K(Y) = I`` and asking ``Y > 0`` (for a positive
        operator the two are equivalent), with the congruence matrices formed
        once: the pattern weights are affine in the coordinate.  With a
        single unstable mode the gains that zero it work all the way down to
        the lower bound (Sinopoli et al. (2004) Sec. IV), so one solve near the threshold
        finishes the search.

        Above :data:`PERRON_MIN_N` states the bisection is first replayed with an estimate of
        where ``rho(L_K)`` crosses 1 (:func:`kfio.riccati_bounds._perron.estimate_crossing`,
        ``O(n^3)`` per operator application) instead of a solve per point, and the solve is
        asked at the two ends the replay reached.  If stability is monotone along the
        coordinate, the assumption of the bisection itself, two agreeing ends mean the same
        decision at every step, hence the same point; otherwise the bisection runs again with a
        solve at every point.
        """
        n = self.A.shape[0]
        closed = [self.A] + [self.A + k @ c for k, c in zip(K, self.C_S)]
        terms: list[np.ndarray] = []  # the congruence matrices, formed at the first dense solve
        rhs = vech(np.eye(n))
        near: list[
            Any
        ] = []  # above DENSE_MAX_N states: the LU factors of the last operator factored, the latest solution

        def stable(x: float) -> bool:
            self._tick("slide")
            weights = self._float_weights(at(Fraction(x)))
            y = None
            if near:  # start from the latest solution: the bisection's points close in, so it is the nearest
                y = solve_near([(w, F) for w, F in zip(weights, closed) if w > 0], near[0], rhs, near[1])
                if y is not None:
                    near[1] = y
            if y is None:
                if not terms:
                    terms.extend(congruence_matrix(F) for F in closed)
                L = np.eye(len(rhs))
                for w, T in zip(weights, terms):
                    if w > 0:
                        L -= w * T
                try:
                    if n > DENSE_MAX_N:
                        factor = scipy.linalg.lu_factor(L, check_finite=False)
                        y = scipy.linalg.lu_solve(factor, rhs, check_finite=False)
                        near[:] = [factor, y]
                    else:  # LAPACK's gesv and potrf without NumPy's per-call checks: the same floats and decisions
                        y = solve_finite(L, rhs)
                        return y is not None and cholesky_succeeds(unvech(y, n))
                except (np.linalg.LinAlgError, ValueError):
                    return False
            try:
                np.linalg.cholesky(unvech(y, n))
            except np.linalg.LinAlgError:
                return False
            return bool(np.all(np.isfinite(y)))

        def bisection(decide: Callable[[float], bool]) -> tuple[float, float]:
            a, b = float(lo), float(hi)
            while b - a > float(tol) / 4:
                c = 0.5 * (a + b)
                a, b = (a, c) if decide(c) else (c, b)
            return a, b

        guess = None
        if n > PERRON_MIN_N and self.perron:
            guess = estimate_crossing(lambda x: self._float_weights(at(Fraction(x))), closed, float(lo), float(hi))
        if guess is not None:
            # replay the bisection with the estimate, then ask the solver at the two ends it reached: if stability
            # is monotone in x (what the bisection assumes), agreeing ends mean agreeing steps all along
            t = guess
            a, b = bisection(lambda c: c > t)
            if (a == float(lo) or not stable(a)) and (b == float(hi) or stable(b)):
                self.guided += 1
            else:
                guess = None
                near.clear()
        if guess is None:
            a, b = bisection(stable)
        x = Fraction(math.ceil(Fraction(b) / GRID)) * GRID
        if not lo < x < hi - tol / 2:
            return None
        cert = self.check_gains(at(x), K, route=route, near=near)  # x is within tol / 4 of the last point solved
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
        the model) and moves down towards ``lower`` (a value where the LMI is
        known to be infeasible, e.g. the closed-form lower bound):

        1. *continuation*: slide the certified gains down to where they stop
           stabilizing, re-optimize them there by policy iteration (the
           MARE's optimal gains at that point), slide again, until a round
           gains less than half the tolerance;
        2. *probe*: one certification attempt one tolerance below (the
           annihilating gains, the refined gains, and the LMI for
           ``n <= LMI_PROBE_MAX_N``); a success restarts step 1 from there
           (and a second stall there falls back to bisection), a failure
           ends the search with the probe's point as ``lower_end``: "not
           certified" there, never a proved infeasibility.

        Why a stall means convergence: the MARE's optimal gains at ``lambda``
        stabilize down to some ``T(lambda) < lambda``, and ``T(lambda) -
        lambda_upper`` shrinks like the square of ``lambda - lambda_upper``
        (the threshold is stationary in the gains at the optimum), so a round
        that gains less than ``tol / 2`` ends within about ``tol`` of
        ``lambda_upper``.  That is evidence, not proof, which is why only the
        upper end is reported as certified.

        With ``lmi_mode == "always"`` this is the plain bisection over LMI
        solves (the reference route).
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
        if self.lmi_mode == "always":
            return self._bisection(at, lo, hi, cert, tol, steps0, lambda x, K: self.certify_lmi(x))
        probed = False
        while hi - lo > tol:
            before = hi
            hi, cert = self._continue(at, lo, hi, cert, tol)
            if hi - lo <= tol:
                break
            if probed and before - hi <= tol:
                # a probe succeeded yet the continuation stalls there: bisect instead of stepping by tol
                return self._bisection(at, lo, hi, cert, tol, steps0, lambda x, K: self.certify(x, prior=K))
            probe = Fraction(math.floor((hi - tol) / GRID)) * GRID
            if not lo < probe < hi:
                break
            c = self.certify(at(probe), prior=cert.K, scratch=False, lmi=self.A.shape[0] <= LMI_PROBE_MAX_N)
            if c is None:
                return UpperBound(hi, cert, probe, self.solves - steps0)
            hi, cert, probed = probe, c, True
        return UpperBound(hi, cert, lo, self.solves - steps0)

    def _continue(
        self,
        at: Callable[[Fraction], list[Fraction]],
        lo: Fraction,
        hi: Fraction,
        cert: StabilityCertificate,
        tol: Fraction,
    ) -> tuple[Fraction, StabilityCertificate]:
        """Step 1 of :meth:`bisect`: slide, re-optimize by policy iteration, slide, ... while it gains."""
        route = cert.route
        K: Sequence[np.ndarray] | None = cert.K
        for _ in range(MAX_ROUNDS):
            if K is None or hi - lo <= tol:
                break
            slid = self._slide(at, lo, hi, K, tol, route)
            if slid is not None:
                hi, cert = slid
            elif K is not cert.K:
                break  # the re-optimized gains gained nothing
            K = self.refine(at(hi), cert.K)
            route = "MARE gains by policy iteration"
        return hi, cert

    def _bisection(
        self,
        at: Callable[[Fraction], list[Fraction]],
        lo: Fraction,
        hi: Fraction,
        cert: StabilityCertificate,
        tol: Fraction,
        steps0: int,
        certify_at: Callable[[list[Fraction], Sequence[np.ndarray]], StabilityCertificate | None],
    ) -> UpperBound:
        """Plain bisection of ``(lo, hi]`` with ``certify_at(lambdas, prior_gains)``, sliding after each success."""
        while hi - lo > tol:
            slid = self._slide(at, lo, hi, cert.K, tol, cert.route)
            if slid is not None:
                hi, cert = slid
                if hi - lo <= tol:
                    break
            mid = ((lo + hi) / 2 / GRID).__round__() * GRID
            if not lo < mid < hi:
                break
            c = certify_at(at(mid), cert.K)
            if c is not None:
                hi, cert = mid, c
            else:
                lo = mid
        return UpperBound(hi, cert, lo, self.solves - steps0)

    def region(self, values: Sequence[Fraction], unstable: np.ndarray) -> tuple[list[list[str]], int]:
        """Label the grid ``values x values`` for two packets: stable / unstable / undecided.

        ``unstable[i, j]`` marks the cells the lower bound proves unstable.
        Stable cells form an up-set (Liu and Goldsmith (2004), Lemma 3), so each column
        ``lambda_1 = values[i]`` needs a binary search for its lowest
        certified cell, and that cell bounds the search of the next column.
        Returns the labels (``labels[i][j]`` for ``(values[i], values[j])``)
        and the number of certified cells that support them.
        """
        K = len(values)
        labels = [["unstable" if unstable[i, j] else "undecided" for j in range(K)] for i in range(K)]
        lowest_prev: int | None = None  # lowest stable index of the previous column
        certified = 0
        last: list[StabilityCertificate] = []  # the latest certificate: its gains seed the next cell

        def cell(lambdas: list[Fraction]) -> StabilityCertificate | None:
            # the MARE from 0 is slow exactly where it fails (below the threshold): refine nearby gains instead
            prior = last[-1].K if last else None
            c = self.certify(lambdas, prior=prior, scratch=prior is None)
            if c is not None:
                last.append(c)
            return c

        for i in range(K):
            free = [j for j in range(K) if not unstable[i, j]]
            if not free:
                continue
            lo_idx = free[0] - 1  # everything <= lo_idx is not certified
            if lowest_prev is not None:
                hi_idx = lowest_prev  # stable by monotonicity in lambda_1
            else:
                if cell([values[i], values[K - 1]]) is None:
                    continue
                certified += 1
                hi_idx = K - 1
            while hi_idx - lo_idx > 1:
                mid = (lo_idx + hi_idx) // 2
                if cell([values[i], values[mid]]) is not None:
                    hi_idx = mid
                    certified += 1
                else:
                    lo_idx = mid
            for j in range(hi_idx, K):
                labels[i][j] = "stable"
            lowest_prev = hi_idx
        return labels, certified
