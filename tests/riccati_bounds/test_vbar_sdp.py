"""The V_bar SDP handed to Clarabel by hand (kfio.riccati_bounds._vbar_conic) against the CVXPY problem built afresh."""

from __future__ import annotations

import cvxpy as cp
import numpy as np
import pytest

from kfio.riccati_bounds import _riccati as riccati
from kfio.riccati_bounds import _vbar_conic, _vbar_sdp
from kfio.riccati_bounds._vbar_sdp import lmi_blocks, v_bar_sdp, v_bar_sdp_fresh

THREE_A = np.array([[1.25, 1, 0], [0, 0.9, 7], [0, 0, 0.6]])
THREE_C = np.array([[1.0, 0, 2]])


def random_model(rng: np.random.Generator, n: int, groups: list[list[int]]) -> riccati.ArrivalModel:
    A = rng.normal(size=(n, n))
    A *= 1.1 / max(abs(np.linalg.eigvals(A)))
    p = max(r for g in groups for r in g) + 1
    C = rng.normal(size=(p, n))
    B = rng.normal(size=(n, n))
    lams = [float(x) for x in rng.uniform(0.6, 0.95, size=len(groups))]
    return riccati.arrival_model(A, C, B @ B.T + np.eye(n), np.eye(p), groups, lams)


def assert_agree(model: riccati.ArrivalModel) -> None:
    compiled, fresh = v_bar_sdp(model), v_bar_sdp_fresh(model)
    assert compiled.status == fresh.status
    assert compiled.matrix is not None and fresh.matrix is not None
    # Clarabel stops within its own tolerance of the optimum; the two problems differ only by
    # rounding in their data, so their answers agree far inside the 1e-7 the bounds allow.
    assert np.linalg.norm(compiled.matrix - fresh.matrix) <= 1e-7 * np.linalg.norm(fresh.matrix)


def svec(M: np.ndarray) -> np.ndarray:
    """Clarabel's triangle form, written out: upper triangle column by column, ``sqrt 2`` off the diagonal."""
    n = M.shape[0]
    return np.array([M[i, j] * (1.0 if i == j else np.sqrt(2.0)) for j in range(n) for i in range(j + 1)])


def gamma(model: riccati.ArrivalModel, V: np.ndarray) -> np.ndarray:
    """The LMI matrix of Sinopoli et al. (2004) Theorem 6(b) at ``V``, block by block."""
    return np.block(lmi_blocks(model, V))


@pytest.mark.parametrize("seed", range(5))
def test_conic_program_is_the_sdp_entry_by_entry(seed: int) -> None:
    """``b - A x`` is ``svec(Gamma(V)), svec(V)`` and ``q'x = -tr V`` for a random symmetric ``V``."""
    rng = np.random.default_rng(40 + seed)
    n = 1 + seed
    groups = [[[0]], [[0, 1]], [[0], [1]], [[0], [1, 2]], [[0, 2], [1]]][seed]
    model = random_model(rng, n, groups)
    q, A, b, cones = _vbar_conic.conic_program(model)
    M = rng.normal(size=(n, n))
    V = M + M.T
    x = np.array([V[i, j] for j in range(n) for i in range(j + 1)])
    want = np.concatenate([svec(gamma(model, V)), svec(V)])
    assert np.allclose(b - A @ x, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())
    assert np.isclose(q @ x, -np.trace(V), rtol=1e-14, atol=1e-14)
    assert len(cones) == 2


def test_status_names_are_cvxpy_names() -> None:
    from cvxpy.reductions.solvers.conic_solvers.clarabel_conif import CLARABEL

    assert _vbar_conic.STATUS == {k: str(v) for k, v in CLARABEL.STATUS_MAP.items()}


def test_unbounded_sdp_says_so_as_cvxpy_does() -> None:
    # lambda = 0.1 is below the critical probability: V_bar does not exist, the trace is unbounded
    model = riccati.one_packet_model(THREE_A, THREE_C, 20 * np.eye(3), np.array([[2.5]]), 0.1)
    direct, fresh = v_bar_sdp(model), v_bar_sdp_fresh(model)
    assert direct.status == fresh.status == cp.UNBOUNDED
    assert direct.matrix is None and fresh.matrix is None


@pytest.mark.parametrize("lam", [0.4, 0.7, 1.0])
def test_compiled_agrees_with_fresh_on_the_3x3_system(lam: float) -> None:
    assert_agree(riccati.one_packet_model(THREE_A, THREE_C, 20 * np.eye(3), np.array([[2.5]]), lam))


@pytest.mark.parametrize("seed", range(8))
def test_compiled_agrees_with_fresh_on_random_systems(seed: int) -> None:
    rng = np.random.default_rng(seed)
    groups = [[[0]], [[0, 1]], [[0], [1]], [[0], [1, 2]]][seed % 4]
    assert_agree(random_model(rng, 1 + seed % 5 + (seed % 4 == 3), groups))


def test_answer_does_not_depend_on_what_was_solved_before() -> None:
    # CVXPY's default warm start updates the previous Clarabel instance in place, which changes
    # the last bits of the answer; a request must get the same bits whatever came before it.
    m1 = riccati.one_packet_model(THREE_A, THREE_C, 20 * np.eye(3), np.array([[2.5]]), 0.4)
    m2 = riccati.one_packet_model(THREE_A, THREE_C, 20 * np.eye(3), np.array([[2.5]]), 0.7)
    first = v_bar_sdp(m1).matrix
    v_bar_sdp(m2)
    again = v_bar_sdp(m1).matrix
    assert first is not None and again is not None
    assert np.array_equal(first, again)


def test_fresh_route_above_the_compiled_size(monkeypatch) -> None:
    monkeypatch.setattr(_vbar_sdp, "COMPILED_MAX_N", 2)
    monkeypatch.setattr(_vbar_sdp, "solve_conic", lambda model: pytest.fail("built by hand above the limit"))
    model = riccati.one_packet_model(THREE_A, THREE_C, 20 * np.eye(3), np.array([[2.5]]), 0.4)
    sol = v_bar_sdp(model)
    assert sol.status == cp.OPTIMAL
    V = riccati.solve_v_bar(model).matrix
    assert np.linalg.norm(sol.matrix - V) <= 1e-6 * np.linalg.norm(V)
