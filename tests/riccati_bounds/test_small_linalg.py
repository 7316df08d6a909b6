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


def _numpy_or_error(f, *args):
    try:
        return f(*args)
    except np.linalg.LinAlgError as e:
        return type(e)


def test_stacked_cholesky_and_solve_are_numpy_bit_for_bit():
    """The batched gain of ``P_hat_N`` (two or more outputs): the same floats, and the same ``LinAlgError``."""
    from kfio.riccati_bounds import _small_linalg

    rng = np.random.default_rng(12)
    with np.errstate(all="ignore"):
        for p in (1, 2, 3, 5):
            for k in range(60):
                B = rng.standard_normal((1 + k % 9, p, p))
                S = B @ B.transpose(0, 2, 1) + (1e-17 if k % 4 == 0 else 1.0) * np.eye(p)
                if k % 6 == 1:
                    S[-1] = -S[-1]  # not positive definite: LinAlgError
                if k % 6 == 2:
                    S[0, 0, 0] = np.nan
                if k % 6 == 3:
                    S[0, -1, -1] = np.inf  # an infinite factor without NaN, or a failure
                if k % 6 == 4:
                    S *= 1e300
                new = _numpy_or_error(_small_linalg.cholesky, S)
                old = _numpy_or_error(np.linalg.cholesky, S)
                if isinstance(old, type):
                    assert new is old
                    continue
                assert np.array_equal(new, old, equal_nan=True)
                rhs = rng.standard_normal((S.shape[0], p, 3))
                L = old.copy()
                if k % 5 == 0 and p > 1:
                    L[0, -1] = 0.0  # exactly singular: LinAlgError
                new_y = _numpy_or_error(_small_linalg.solve, L, rhs)
                old_y = _numpy_or_error(np.linalg.solve, L, rhs)
                if isinstance(old_y, type):
                    assert new_y is old_y
                else:
                    assert np.array_equal(new_y, old_y, equal_nan=True)
