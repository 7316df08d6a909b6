"""The compiled V_bar SDP (kfio.riccati_bounds._vbar_sdp) against the problem built afresh, and its cache."""

from __future__ import annotations

import cvxpy as cp
import numpy as np
import pytest

from kfio.riccati_bounds import _riccati as riccati
from kfio.riccati_bounds import _vbar_sdp
from kfio.riccati_bounds._vbar_sdp import VBarSDP, v_bar_sdp, v_bar_sdp_fresh

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


def test_compiled_problem_is_dpp() -> None:
    assert VBarSDP(3, (1,)).is_dpp()
    assert VBarSDP(2, (2, 2, 4)).is_dpp()


@pytest.mark.parametrize("lam", [0.4, 0.7, 1.0])
def test_compiled_agrees_with_fresh_on_the_3x3_system(lam: float) -> None:
    assert_agree(riccati.one_packet_model(THREE_A, THREE_C, 20 * np.eye(3), np.array([[2.5]]), lam))


@pytest.mark.parametrize("seed", range(4))
def test_compiled_agrees_with_fresh_on_random_systems(seed: int) -> None:
    rng = np.random.default_rng(seed)
    groups = [[[0]], [[0, 1]], [[0], [1]], [[0], [1, 2]]][seed]
    assert_agree(random_model(rng, 2 + seed, groups))


def test_answer_does_not_depend_on_what_was_solved_before() -> None:
    # CVXPY's default warm start updates the previous Clarabel instance in place, which changes
    # the last bits of the answer; a request must get the same bits whatever came before it.
    _vbar_sdp._CACHE.clear()
    m1 = riccati.one_packet_model(THREE_A, THREE_C, 20 * np.eye(3), np.array([[2.5]]), 0.4)
    m2 = riccati.one_packet_model(THREE_A, THREE_C, 20 * np.eye(3), np.array([[2.5]]), 0.7)
    first = v_bar_sdp(m1).matrix
    v_bar_sdp(m2)
    again = v_bar_sdp(m1).matrix
    assert first is not None and again is not None
    assert np.array_equal(first, again)


def test_cache_is_per_shape_and_bounded() -> None:
    _vbar_sdp._CACHE.clear()
    rng = np.random.default_rng(5)
    for n in range(1, _vbar_sdp.CACHE_SIZE + 3):
        v_bar_sdp(random_model(rng, n, [[0]]))
    assert len(_vbar_sdp._CACHE) == _vbar_sdp.CACHE_SIZE
    v_bar_sdp(random_model(rng, _vbar_sdp.CACHE_SIZE + 2, [[0]]))
    assert len(_vbar_sdp._CACHE) == _vbar_sdp.CACHE_SIZE


def test_fresh_route_above_the_compiled_size(monkeypatch) -> None:
    monkeypatch.setattr(_vbar_sdp, "COMPILED_MAX_N", 2)
    _vbar_sdp._CACHE.clear()
    model = riccati.one_packet_model(THREE_A, THREE_C, 20 * np.eye(3), np.array([[2.5]]), 0.4)
    sol = v_bar_sdp(model)
    assert not _vbar_sdp._CACHE
    assert sol.status == cp.OPTIMAL
    V = riccati.solve_v_bar(model).matrix
    assert np.linalg.norm(sol.matrix - V) <= 1e-6 * np.linalg.norm(V)
