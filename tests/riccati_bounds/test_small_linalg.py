"""The direct LAPACK calls of the slide give NumPy's floats and decisions, on random and borderline matrices."""

from __future__ import annotations

import numpy as np

from kfio.riccati_bounds._small_linalg import cholesky_succeeds, solve_finite


def _old_solve(L, rhs):
    try:
        y = np.linalg.solve(L, rhs)
    except np.linalg.LinAlgError:
        return None
    return y if np.all(np.isfinite(y)) else None


def _old_cholesky(M):
    try:
        np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        return False
    return True


def test_solve_finite_is_numpy_solve_bit_for_bit():
    rng = np.random.default_rng(11)
    for size in (1, 3, 6, 10, 15):
        for k in range(40):
            L = rng.standard_normal((size, size))
            if k % 5 == 0 and size > 1:
                L[-1] = L[0]  # exactly singular
            if k % 7 == 0:
                L *= 1e300  # overflow towards inf in the solution or the factors
            rhs = rng.standard_normal(size)
            new, old = solve_finite(L, rhs), _old_solve(L, rhs)
            assert (new is None) == (old is None)
            if old is not None:
                assert np.array_equal(new, old)


def test_cholesky_succeeds_is_numpy_cholesky():
    rng = np.random.default_rng(12)
    decided = set()
    for size in (1, 2, 3, 4, 5):
        for k in range(200):
            B = rng.standard_normal((size, size))
            M = B @ B.T
            # push the smallest eigenvalue around zero, down to rounding level
            w, V = np.linalg.eigh(M)
            w[0] = rng.choice([-1.0, 1.0]) * 10.0 ** -rng.integers(0, 18) * w[-1]
            if k % 10 == 0:
                w[0] = 0.0
            M = (V * w) @ V.T
            M = 0.5 * (M + M.T)
            old = _old_cholesky(M)
            assert cholesky_succeeds(M) == old
            decided.add(old)
    assert decided == {True, False}
