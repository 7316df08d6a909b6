"""``congruence_matrix`` against the Kronecker definition ``vec(M X M') = (M (x) M) vec(X)``."""

from __future__ import annotations

import numpy as np
import pytest

from kfio.riccati_bounds._vech import congruence_matrix, unvech, vech, vech_layout


def kron_reference(M: np.ndarray) -> np.ndarray:
    n = M.shape[0]
    iu, ju, dup = vech_layout(n)
    return (np.kron(M, M) @ dup)[iu * n + ju]


@pytest.mark.parametrize("n", [1, 2, 3, 5, 12])
def test_congruence_matrix_equals_the_kronecker_form_bit_for_bit(n) -> None:
    rng = np.random.default_rng(n)
    M = rng.normal(size=(n, n)) * 10.0 ** rng.integers(-3, 4, size=(n, n))
    T = congruence_matrix(M)
    assert np.array_equal(T, kron_reference(M))  # same two products added per entry, halving 2ab is exact
    X = rng.normal(size=(n, n))
    X = X + X.T
    assert np.allclose(unvech(T @ vech(X), n), M @ X @ M.T, rtol=1e-12, atol=1e-12 * np.abs(M).max() ** 2)
