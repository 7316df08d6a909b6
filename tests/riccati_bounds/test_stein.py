"""The GMRES solvers of the generalized Stein equation (kfio.riccati_bounds._stein) against the dense vech solve.

The reference is the ``vech`` linear system ``(I - sum_i w_i T(M_i)) vech(X) = vech(W)`` with
``T`` from :func:`kfio.riccati_bounds._vech.congruence_matrix` (itself checked against the
Kronecker form in test_vech.py), solved by LU.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from kfio.riccati_bounds import _riccati, _stein
from kfio.riccati_bounds._certificate import lyapunov_certificate
from kfio.riccati_bounds._gains import normalized_model
from kfio.riccati_bounds._riccati import closed_loop_operator, gains, solve_v_bar
from kfio.riccati_bounds._stein import DENSE_MAX_N, apply, solve_near, solve_stein
from kfio.riccati_bounds._vech import congruence_matrix, unvech, vech

from support.stein_dense import dense


def case(seed: int, n: int, rows: list[int]):
    """A random plant with stabilizing-ish gains per pattern and random pattern weights."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    A *= rng.uniform(0.8, 1.3) / max(abs(np.linalg.eigvals(A)))
    C = [rng.normal(size=(p, n)) for p in rows]
    K = [-A @ c.T @ np.linalg.inv(c @ c.T + np.eye(p)) * rng.uniform(0.5, 1.0) for c, p in zip(C, rows)]
    w = rng.dirichlet(np.ones(len(rows) + 1))
    terms = [(float(w[0]), A)] + [(float(wi), A + k @ c) for wi, k, c in zip(w[1:], K, C)]
    B = rng.normal(size=(n, n))
    return terms, [np.eye(n), B @ B.T]


def spectral_radius(terms) -> float:
    return float(max(abs(np.linalg.eigvals(sum(w * congruence_matrix(M) for w, M in terms)))))


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("n,rows", [(3, [1]), (13, [2]), (16, [1, 1, 2]), (24, [2])])
def test_gmres_agrees_with_dense(seed: int, n: int, rows: list[int]) -> None:
    terms, rhs = case(seed, n, rows)
    fast = solve_stein(terms, rhs)
    if spectral_radius(terms) >= 0.999:
        return  # not mean-square stable: nothing to compare (the callers test stability themselves)
    assert fast is not None  # the residual check must pass on these cases
    for X, W in zip(fast, rhs):
        Y = dense(terms, W)
        assert np.linalg.norm(X - Y) <= 1e-9 * np.linalg.norm(Y)
        assert np.array_equal(X, X.T)
        assert np.linalg.norm(X - apply(terms, X) - W) <= 1e-9 * np.linalg.norm(X)


def test_near_threshold_within_the_bound() -> None:
    """A weight just below the mean-square threshold: ``X`` is huge and the dense solve is the reference."""
    terms, rhs = case(3, 14, [2])
    (w0, A), (w1, F) = terms
    lo, hi = 0.0, 1.0  # scale the open-loop weight until rho(L) crosses 1
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        trial = [(w0 + mid * (1 - w0 - w1), A), (w1, F)]
        lo, hi = (mid, hi) if spectral_radius(trial) < 1 else (lo, mid)
    near = [(w0 + 0.999 * lo * (1 - w0 - w1), A), (w1, F)]
    fast = solve_stein(near, rhs[:1])
    assert fast is not None
    Y = dense(near, rhs[0])
    assert np.linalg.norm(fast[0] - Y) <= 1e-7 * np.linalg.norm(Y)


def test_gmres_stops_when_rounding_stalls_it_near_the_threshold(monkeypatch) -> None:
    """Closer to the threshold (``1 - rho = 1e-9``) the residual cannot reach ``1e-12 ||W||``: GMRES stops after
    the first cycle that fails to halve it (not after all ``MAX_RESTARTS``), and the answer still matches the dense
    solve, or the dense solve answers."""
    terms, rhs = case(3, 14, [2])
    rho = spectral_radius(terms)
    near = [(w * (1 - 1e-9) / rho, M) for w, M in terms]  # L is linear in the weights: rho(L) = 1 - 1e-9
    cycles = []
    gmres = _stein._gmres

    def counted(op, pre, b, x, tol, cycles_=0):
        calls = [0]

        def op_counted(v):
            calls[0] += 1
            return op(v)

        out = gmres(op_counted, pre, b, x, tol, cycles_)
        cycles.append(calls[0])
        return out

    monkeypatch.setattr(_stein, "_gmres", counted)
    fast = solve_stein(near, rhs[:1])
    assert cycles and cycles[0] < 3 * (_stein.RESTART + 1)  # at most two cycles and the final residual
    Y = dense(near, rhs[0])
    if fast is not None:
        assert np.linalg.norm(fast[0] - Y) <= 1e-5 * np.linalg.norm(Y)


def test_solve_near_with_a_nearby_factorization() -> None:
    terms, rhs = case(5, 15, [2])
    (w0, A), (w1, F) = terms
    n = A.shape[0]
    L = np.eye(n * (n + 1) // 2) - w0 * congruence_matrix(A) - w1 * congruence_matrix(F)
    factor = scipy.linalg.lu_factor(L)
    start = scipy.linalg.lu_solve(factor, vech(rhs[0]))
    moved = [(w0 * 0.98, A), (w1 + 0.02 * w0, F)]
    h = solve_near(moved, factor, vech(rhs[0]), start)
    assert h is not None
    Y = dense(moved, rhs[0])
    assert np.linalg.norm(unvech(h, n) - Y) <= 1e-9 * np.linalg.norm(Y)


def test_no_usable_preconditioner_declines() -> None:
    A = np.diag([1.5, 1.2] + [0.5] * 12)
    assert solve_stein([(1.0, A)], [np.eye(14)]) is None  # its own Stein equation is not stable


def test_callers_keep_the_dense_route_up_to_dense_max_n(monkeypatch) -> None:
    def boom(*args, **kwargs):
        raise AssertionError("the GMRES route was used at n <= DENSE_MAX_N")

    monkeypatch.setattr(_riccati, "solve_stein", boom)
    terms, _ = case(0, DENSE_MAX_N, [1])
    (w0, A), (w1, F) = terms
    C = np.random.default_rng(0).normal(size=(1, DENSE_MAX_N))
    model = normalized_model(A, [C], [w0, w1])
    it = solve_v_bar(model)
    if it.matrix is not None:
        assert it.newton_steps >= 1


@pytest.mark.parametrize("n", [DENSE_MAX_N + 1, DENSE_MAX_N + 4])
def test_policy_evaluation_and_certificate_match_the_dense_route(n: int, monkeypatch) -> None:
    rng = np.random.default_rng(n)
    A = rng.normal(size=(n, n))
    A *= 1.1 / max(abs(np.linalg.eigvals(A)))
    C = rng.normal(size=(2, n))
    model = normalized_model(A, [C], [0.2, 0.8])
    V = solve_v_bar(model).matrix
    assert V is not None
    K = gains(V, model)
    X = _riccati.policy_evaluation(model, K)
    Xc = lyapunov_certificate(model, K)
    m = n * (n + 1) // 2
    M = np.eye(m) - closed_loop_operator(model, K)
    W = model.Q + 0.8 * K[0] @ K[0].T
    assert X is not None and Xc is not None
    ref = unvech(np.linalg.solve(M, vech(0.5 * (W + W.T))), n)
    refc = unvech(np.linalg.solve(M, vech(np.eye(n))), n)
    assert np.linalg.norm(X - ref) <= 1e-9 * np.linalg.norm(ref)
    assert np.linalg.norm(Xc - refc) <= 1e-9 * np.linalg.norm(refc)
    assert _riccati.policy_evaluation(model, (np.zeros((n, 2)),)) is None  # open loop at 0.2 loss: unstable
