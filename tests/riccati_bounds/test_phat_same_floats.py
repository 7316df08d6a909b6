"""``g_N`` with its tree weights formed once per ``N`` gives the floats of the level-by-level recursion bit for bit.

``kfio bounds`` prints ``P_hat_N`` (Rohr, Marelli and Fu (2010), eq. 15) in full and the number
of iterations, so the faster evaluation must not change one bit of any iterate.  The reference
here is the straightforward form of the recursion of eq. 11 on batches: every level forms its
weights again.
"""

from __future__ import annotations

import numpy as np
import pytest

from kfio.riccati_bounds import _phat
from kfio.riccati_bounds._phat import BatchedMare, p_hat_sequence
from kfio.riccati_bounds._vech import vech


def reference_correction(op: BatchedMare, h: np.ndarray) -> np.ndarray:
    AXC = h @ op._AXC
    S = h @ op._CXC + op._r
    if op.p == 1:
        G = AXC / np.sqrt(S)
        return G[:, op._iu] * G[:, op._ju]
    L = np.linalg.cholesky(S.reshape(-1, op.p, op.p))
    G = np.linalg.solve(L, AXC.reshape(-1, op.n, op.p).transpose(0, 2, 1))
    return np.einsum("bki,bki->bi", G[:, :, op._iu], G[:, :, op._ju])


def reference_descend(op: BatchedMare, level: np.ndarray, w: np.ndarray, depth: int) -> np.ndarray:
    lam = op.lam
    while depth > 1:
        b = level.shape[0]
        if b > 1 and b << (depth - 1) > 1 << _phat.CHUNK_LEVELS:
            half = b // 2
            return reference_descend(op, level[:half], w[:half], depth) + reference_descend(
                op, level[half:], w[half:], depth
            )
        phi0 = level @ op._AXA
        phi0 += op._q
        nxt = np.empty((2 * b, level.shape[1]))
        nxt[:b] = phi0
        np.subtract(phi0, reference_correction(op, level), out=nxt[b:])
        level, w = nxt, np.concatenate([w * (1.0 - lam), w * lam])
        depth -= 1
    return (w @ level) @ op._AXA + w.sum() * op._q - lam * (w @ reference_correction(op, level))


def random_plant(rng: np.random.Generator, n: int, p: int):
    A = rng.normal(size=(n, n))
    A *= rng.uniform(1.0, 1.3) / np.max(np.abs(np.linalg.eigvals(A)))
    return A, rng.normal(size=(p, n)), np.eye(n), np.eye(p)


@pytest.mark.parametrize("seed", range(6))
def test_g_n_is_the_recursion_bit_for_bit(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n, p = 1 + seed % 5, 1 + seed % 2
    A, C, Q, R = random_plant(rng, n, p)
    op = BatchedMare(A, C, Q, R, rng.uniform(0.5, 0.95))
    M = rng.normal(size=(n, n))
    h = vech(M @ M.T + np.eye(n))
    for N in (1, 2, 3, 5, 8):
        for _ in range(2):  # the second call uses the weights formed by the first
            assert np.array_equal(op.g_n(h, N), reference_descend(op, h[None, :], np.ones(1), N))


def test_chunked_levels_are_the_recursion_bit_for_bit(monkeypatch) -> None:
    monkeypatch.setattr(_phat, "CHUNK_LEVELS", 3)  # chunking from N = 5 on
    rng = np.random.default_rng(7)
    A, C, Q, R = random_plant(rng, 3, 1)
    op = BatchedMare(A, C, Q, R, 0.7)
    h = vech(4 * np.eye(3))
    for N in (4, 5, 7):
        assert np.array_equal(op.g_n(h, N), reference_descend(op, h[None, :], np.ones(1), N))


def test_fixed_points_keep_their_iterates(monkeypatch) -> None:
    rng = np.random.default_rng(3)
    A, C, Q, R = random_plant(rng, 3, 1)
    new = p_hat_sequence(A, C, Q, R, 0.8, [1, 2, 4, 8])
    monkeypatch.setattr(BatchedMare, "g_n", lambda op, h, N: reference_descend(op, h[None, :], np.ones(1), N))
    old = p_hat_sequence(A, C, Q, R, 0.8, [1, 2, 4, 8])
    assert new.keys() == old.keys()
    for N in new:
        a, b = new[N], old[N]
        assert (a.iterations, a.last_step, a.start, a.reason) == (b.iterations, b.last_step, b.start, b.reason)
        assert a.matrix is not None and np.array_equal(a.matrix, b.matrix)
    assert new[8].iterations > 1


@pytest.mark.parametrize("n", range(1, 6))
def test_g_n_keeps_every_bit_on_random_plants(n: int) -> None:
    """The level loop with ``take`` gathers and the cached ``(sum w) Q``, against the old recursion."""
    rng = np.random.default_rng(100 + n)
    for trial in range(8):
        p = 1 + trial % 2 if n > 1 else 1
        A, C, Q, R = random_plant(rng, n, p)
        op = BatchedMare(A, C, Q, R, rng.uniform(0.3, 0.97))
        M = rng.normal(size=(n, n))
        h = vech(M @ M.T + rng.uniform(0.1, 10.0) * np.eye(n))
        for N in (1, 2, 3, 4, 6, 9):
            assert np.array_equal(op.g_n(h, N), reference_descend(op, h[None, :], np.ones(1), N))


def test_last_correction_has_the_layout_and_floats_of_fancy_indexing() -> None:
    """The last level's products are laid out as ``G[:, iu] * G[:, ju]`` lays them out, since a GEMV sums them."""
    rng = np.random.default_rng(11)
    A, C, Q, R = random_plant(rng, 4, 1)
    op = BatchedMare(A, C, Q, R, 0.6)
    for b in (1, 2, 5, 64):
        level = np.array([vech(M @ M.T + np.eye(4)) for M in rng.normal(size=(b, 4, 4))])
        old, new = reference_correction(op, level), op._last_correction(level)
        assert np.array_equal(old, new) and old.strides == new.strides
        assert np.array_equal(op._inner_correction(level), old)
