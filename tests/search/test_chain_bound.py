"""The largest-chain bound of the Pareto walk's plane cuts, against the labelled chains.

:func:`kfio.search._chains.longest_chain` settles a flat before the chains
are labelled: its count (largest chain plus short rows) must never fall
below that of :func:`kfio.search._pareto_proof.parallel_chains`, or the
walk would cut a flat the labelled test keeps.  Planted configurations put
rows near the gap threshold, across the wrap at ``pi`` and near the short
threshold, where the diamond angle and the margins matter.
"""

from __future__ import annotations

import numpy as np
import pytest

import kfio.search._pareto_proof as proof
from kfio.search._chains import longest_chain

SEED = 20261205


def _labelled_count(W: np.ndarray, rows: np.ndarray, tol: float) -> np.ndarray:
    labels, short = proof.parallel_chains(W, rows, tol)
    best = np.array([np.bincount(lab[lab >= 0]).max() if (lab >= 0).any() else 0 for lab in labels])
    return np.asarray(best + short.sum(axis=1))


@pytest.mark.parametrize("spread", [0.0, 0.5, 1.0, 1.5, 3.0])
def test_the_bound_is_never_below_the_labelled_chains(spread: float) -> None:
    rng = np.random.default_rng([SEED, int(10 * spread)])
    gap = 2.0 / proof._SHORT
    for _ in range(40):
        C, n = 60, 14
        tol = float(rng.choice([1e-9, 1e-7]))
        dirs = rng.uniform(-0.01, np.pi + 0.01, size=(C, 3))  # some classes straddle the wrap
        label = rng.integers(0, 3, size=(C, n))
        # Steps of about ``spread`` gap thresholds inside each class: chains that just hold or just break.
        angle = np.take_along_axis(dirs, label, axis=1) + np.cumsum(rng.uniform(0, spread * gap, size=(C, n)), axis=1)
        length = rng.uniform(0.1, 3.0, size=(C, n)) * rng.choice([-1, 1], size=(C, n))
        near_short = rng.random((C, n)) < 0.15
        length[near_short] = proof._SHORT * tol * rng.uniform(0.98, 1.02, size=int(near_short.sum()))
        W = np.stack([length * np.cos(angle), length * np.sin(angle)], axis=2)
        W[rng.random((C, n)) < 0.03] = 0.0
        rows = rng.random((C, n)) < 0.85
        best, short = longest_chain(W, rows, tol)
        assert ((best + short) >= _labelled_count(W, rows, tol)).all()


def test_rows_in_general_position_are_single_chains() -> None:
    rng = np.random.default_rng([SEED, 99])
    W = rng.normal(size=(200, 12, 2))
    rows = np.ones((200, 12), dtype=bool)
    best, short = longest_chain(W, rows, 1e-12)
    assert (short == 0).all()
    assert (best >= _labelled_count(W, rows, 1e-12)).all()
    assert (best == 1).mean() > 0.9, "random directions rarely fall within the gap threshold"


def _pivot_reference(W: np.ndarray, rows: np.ndarray, need: np.ndarray, tol: float) -> np.ndarray:
    """Batch rows where some pivot of ``pivot_projections`` leaves a chain of ``need`` rows (the walk's test before)."""
    found = np.zeros(W.shape[0], dtype=bool)
    for c, _, V, members in proof.pivot_projections(W, rows, need):
        best, short = longest_chain(V, members, tol)
        found[c[best + short >= need[c]]] = True
    return found


def test_plane_candidates_keep_every_flat_a_pivot_keeps_and_every_planted_plane() -> None:
    rng = np.random.default_rng([SEED, 7])
    tol = 1e-9
    for _ in range(20):
        C, n = 80, 16
        W = rng.normal(size=(C, n, 3)) * rng.uniform(0.2, 3.0, size=(C, n, 1))
        planted = np.zeros((C, n), dtype=bool)
        for c in range(C):
            if rng.random() < 0.5:
                normal = rng.normal(size=3)
                normal /= np.linalg.norm(normal)
                on = rng.choice(n, size=int(rng.integers(3, 8)), replace=False)
                W[c, on] -= (W[c, on] @ normal)[:, None] * normal[None, :]
                W[c, on] += rng.uniform(-0.9, 0.9, size=(on.size, 1)) * tol * normal[None, :]
                planted[c, on] = True
        rows = rng.random((C, n)) < 0.9
        rows |= planted
        need = rng.integers(2, 8, size=C)
        got = _plane_candidates(W, rows, need, 3 * tol)
        want = _pivot_reference(W, rows, need, 3 * tol)
        assert not (want & ~got).any(), "a flat a pivot keeps is kept"
        assert got[planted.sum(axis=1) >= need].all(), "a plane of need rows is kept"
        assert not got[~planted.any(axis=1) & (need >= 5)].any(), "rows in general position hold no plane of five"


def _plane_candidates(W: np.ndarray, rows: np.ndarray, need: np.ndarray, tol: float) -> np.ndarray:
    from kfio.search._chains import plane_candidates

    return plane_candidates(W, rows, need, tol)
