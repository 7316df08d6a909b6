"""S_bar <= lim E[P_t] <= P_hat_N <= V_bar (Sinopoli et al. (2004), eq. (23); Rohr, Marelli and Fu (2010), eq. (18)), by simulation.

Bernoulli, one packet, above the threshold and above Rohr, Marelli and Fu (2010)'s variance condition
``lambda > 1 - 1/rho(A)^4`` (so trace(P_t) has a finite variance and the Monte Carlo band is
meaningful).  ``lim E[P_t]`` is checked two ways: the exact enumerated ``E[P_20]`` (levelled off:
it changes by less than 0.1% per step at t = 20, the slowest case being Sinopoli et al. (2004)'s 3x3 system whose
stable eigenvalue 0.9 relaxes like 0.81^t) and the Monte Carlo mean at t = 300 (within 4 standard
errors of ``E[P_20]`` and inside the sandwich).

The bounds come from two routes: ``kfio.riccati_bounds._riccati`` (another engineer's module; skipped while it
does not exist) and local reference computations written here from the seeds' definitions
(S_bar: Lyapunov equation; V_bar: the MARE iterated from 0, Sinopoli et al. (2004) Theorem 4; P_hat_N: Rohr, Marelli and Fu (2010)'s
recursion (22), with g_N evaluated by our own enumeration).  When both exist they must agree.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.linalg import solve_discrete_lyapunov

from kfio import load_request
from kfio.model._types import Request, to_float
from kfio.simulation._finite_horizon import enumerate_expectation, expected_covariance
from kfio.simulation._setup import sim_system
from kfio.simulation._simulate import simulate

N_HAT = 6

CASES = {
    "scalar": ({"A": [[-1.25]], "C": [[1]], "Q": [[1]], "R": [[2.5]]}, 0.7),
    "seed004_3x3": (
        {
            "A": [[1.25, 1, 0], [0, 0.9, 7], [0, 0, 0.6]],
            "C": [[1, 0, 2]],
            "Q": [[20, 0, 0], [0, 20, 0], [0, 0, 20]],
            "R": [[2.5]],
        },
        0.7,
    ),
    "seed004_2x2": ({"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]], "Q": [[20, 0], [0, 20]], "R": [[2.5]]}, 0.8),
}


def make(system: dict, lam: float, simulate_opts: dict | None = None) -> Request:
    body: dict = {"system": system, "channel": {"model": "bernoulli", "arrival_probability": lam}}
    if simulate_opts:
        body["options"] = {"simulate": simulate_opts}
    return load_request(json.dumps(body))


# --- local reference bounds -----------------------------------------------------------------------------


def local_s_bar(A: np.ndarray, Q: np.ndarray, lam: float) -> np.ndarray:
    """S = (1 - lambda) A S A' + Q (Sinopoli et al. (2004), Theorem 4 lower bound)."""
    return solve_discrete_lyapunov(np.sqrt(1 - lam) * A, Q)


def local_v_bar(A, C, Q, R, lam: float, iters: int = 100_000) -> np.ndarray:
    """Fixed point of the MARE g_lambda, iterated from 0 (monotone, Sinopoli et al. (2004) Theorem 4)."""
    X = np.zeros_like(A)
    for _ in range(iters):
        Y = A @ X @ A.T + Q - lam * A @ X @ C.T @ np.linalg.solve(C @ X @ C.T + R, C @ X @ A.T)
        if np.allclose(Y, X, rtol=1e-13, atol=0):
            return Y
        X = Y
    raise AssertionError("MARE iteration did not converge")


def local_p_hat(req: Request, N: int, iters: int = 2_000) -> np.ndarray:
    """Rohr, Marelli and Fu (2010), eq. (22): X <- g_N(X) from 0, with g_N(X) = E[P_N | P_0 = X] by enumeration."""
    sim = sim_system(req)
    X = np.zeros((sim.n, sim.n))
    for _ in range(iters):
        Y = enumerate_expectation(sim, X, N)[0][N]
        if np.allclose(Y, X, rtol=1e-12, atol=0):
            return Y
        X = Y
    raise AssertionError("g_N iteration did not converge")


def _riccati(names: tuple[str, ...]):
    """``kfio.riccati_bounds._riccati``, which must have every one of ``names``."""
    from kfio.riccati_bounds import _riccati as riccati

    missing = [f for f in names if not hasattr(riccati, f)]
    assert not missing, f"kfio.riccati_bounds._riccati has no {', '.join(missing)}"
    return riccati


def bounds(route: str, req: Request, lam: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    A, C, Q, R = (to_float(getattr(req.system, k)) for k in ("A", "C", "Q", "R"))
    if route == "riccati":
        from kfio.riccati_bounds._phat import p_hat

        riccati = _riccati(("s_bar", "v_bar"))
        s, v, p = riccati.s_bar(A, Q, 1 - lam), riccati.v_bar(A, C, Q, R, lam), p_hat(A, C, Q, R, lam, N_HAT)
        assert s is not None and v is not None
        return np.asarray(s), np.asarray(p), np.asarray(v)
    return local_s_bar(A, Q, lam), local_p_hat(req, N_HAT), local_v_bar(A, C, Q, R, lam)


def assert_psd(M: np.ndarray, scale: float) -> None:
    assert np.linalg.eigvalsh((M + M.T) / 2).min() >= -1e-9 * scale


@pytest.mark.slow
@pytest.mark.parametrize("route", ["local", "riccati"])
@pytest.mark.parametrize("name", sorted(CASES))
def test_bounds_sandwich_the_limit(name: str, route: str) -> None:
    system, lam = CASES[name]
    req = make(system, lam)
    s_bar, p_hat, v_bar = bounds(route, req, lam)
    exact = expected_covariance(req, 20)
    E = exact.mean_covariance[-1]
    assert exact.growth_per_step(4) == pytest.approx(1.0, abs=1e-3)  # levelled off
    scale = np.trace(v_bar)
    # matrix order (Sinopoli et al. (2004), eq. (23); Rohr, Marelli and Fu (2010), eq. (18))
    assert_psd(E - s_bar, scale)
    assert_psd(p_hat - E, scale)
    assert_psd(v_bar - p_hat, scale)
    assert np.trace(s_bar) < np.trace(E) < np.trace(p_hat) <= np.trace(v_bar) * (1 + 1e-12)

    # Monte Carlo at a long horizon: the mean is inside the sandwich within 4 standard errors
    rep = simulate(make(system, lam, {"steps": 300, "trajectories": 3_000, "seed": 2}))
    mean, se = rep.mean_trace[-1], rep.stats.sem[-1]
    assert np.trace(s_bar) <= mean + 4 * se
    assert mean - 4 * se <= np.trace(p_hat)
    assert abs(mean - np.trace(E)) <= 4 * se


@pytest.mark.parametrize("name", sorted(CASES))
def test_riccati_s_bar_and_v_bar_agree_with_local_references(name: str) -> None:
    riccati = _riccati(("s_bar", "v_bar"))
    system, lam = CASES[name]
    A, C, Q, R = (to_float(getattr(make(system, lam).system, k)) for k in ("A", "C", "Q", "R"))
    np.testing.assert_allclose(riccati.s_bar(A, Q, 1 - lam), local_s_bar(A, Q, lam), rtol=1e-8)
    np.testing.assert_allclose(riccati.v_bar(A, C, Q, R, lam), local_v_bar(A, C, Q, R, lam), rtol=1e-8)


@pytest.mark.parametrize("name", sorted(CASES))
def test_riccati_p_hat_agrees_with_enumeration(name: str) -> None:
    from kfio.riccati_bounds._phat import p_hat

    system, lam = CASES[name]
    req = make(system, lam)
    A, C, Q, R = (to_float(getattr(req.system, k)) for k in ("A", "C", "Q", "R"))
    np.testing.assert_allclose(p_hat(A, C, Q, R, lam, N_HAT), local_p_hat(req, N_HAT), rtol=1e-8)
