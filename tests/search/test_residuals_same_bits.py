"""The real one-row closure residuals are the bits of the general one-row formula.

``kfio.search._blind_batch._real_line_residuals`` forms ``(W_t . u_e) u_e`` one column at a
time instead of by a broadcast; every rank decision of the walk compares these residuals with a
tolerance and records the margins that the answer's notes print, so the two must agree bit for
bit, not within a tolerance.  The reference below is the formula the walk used before (and still
uses for complex rows).
"""

from __future__ import annotations

import numpy as np
import pytest

from kfio.search._blind_batch import _real_line_residuals, _residuals

SEED = 20261204


def general_one_row(rows: np.ndarray, e: np.ndarray) -> np.ndarray:
    """``||W_t - (W_t u_e^*) u_e||`` with the broadcast product, conjugates included (a no-op on real rows).

    A pinned copy of ``_blind_batch._line_residuals`` as it stood, not an import: the bits to keep
    are those of this formula, whatever later becomes of that function.
    """
    ue = rows[np.arange(rows.shape[0]), e]
    u = ue / np.linalg.norm(ue, axis=1)[:, None]
    coef = rows @ u.conj()[:, :, None]
    diff = rows - coef * u[:, None, :]
    return np.sqrt(np.einsum("csd,csd->cs", diff, diff.conj()).real)


def rows_with_classes(rng: np.random.Generator, pairs: int, S: int, d: int) -> np.ndarray:
    """Random real rows in which many slots are (nearly) parallel, as the flats of a walk have."""
    rows = rng.standard_normal((pairs, S, d))
    directions = rng.standard_normal((pairs, 3, d))
    pick = rng.integers(0, 3, size=(pairs, S))
    parallel = rng.random((pairs, S)) < 0.5
    scale = rng.standard_normal((pairs, S, 1))
    near = directions[np.arange(pairs)[:, None], pick] * scale
    near += 1e-15 * rng.standard_normal(near.shape)  # rounding noise: residuals near the tolerance
    rows[parallel] = near[parallel]
    rows[:, 0] *= 1e-12  # a short row
    return rows


@pytest.mark.parametrize("d", [1, 2, 3, 4, 7])
def test_real_line_residuals_are_the_general_formula_bit_for_bit(d: int) -> None:
    rng = np.random.default_rng(SEED + d)
    for pairs, S in [(1, 5), (37, 84), (300, 21)]:
        rows = rows_with_classes(rng, pairs, S, d)
        e = rng.integers(1, S, size=pairs)
        got = _real_line_residuals(rows, e)
        want = general_one_row(rows, e)
        assert got.shape == (pairs, S)
        assert np.array_equal(got, want), f"d = {d}: largest difference {np.abs(got - want).max():.3g}"


def test_residuals_routes_real_rows_through_it_and_keeps_complex_rows() -> None:
    rng = np.random.default_rng(SEED)
    S, d = 30, 3
    W = rng.standard_normal((4, S, 1, d))
    b = np.array([0, 0, 1, 2, 3, 3])
    e = np.array([1, 5, 2, 9, 4, 7])
    rank = np.ones((4, S), dtype=int)
    assert np.array_equal(_residuals(W, W[:, :, 0, 0] > 0, b, e, rank), general_one_row(W[b, :, 0, :], e))
    Wc = W + 1j * rng.standard_normal(W.shape)
    got = _residuals(Wc, W[:, :, 0, 0] > 0, b, e, rank)
    assert np.array_equal(got, general_one_row(Wc[b, :, 0, :], e))
    # A residual vanishes on the slot itself and on a slot parallel to it.
    W[1, 3, 0] = -2.5 * W[1, 2, 0]
    res = _residuals(W, W[:, :, 0, 0] > 0, np.array([1]), np.array([2]), rank)
    assert res[0, 2] <= 1e-15 and res[0, 3] <= 1e-14 and res[0, 4] > 1e-3


def test_margins_record_the_extremes_of_each_side() -> None:
    """``Margins.record``: the largest value called zero and the smallest called non-zero, over every call."""
    from kfio.search._blind import Margins

    rng = np.random.default_rng(SEED)
    margins = Margins(tol=1e-9)
    seen_zero, seen_nonzero = 0.0, float("inf")
    for shape in [(0,), (3, 0), (5,), (4, 7), (2, 3, 4)]:
        values = np.abs(rng.standard_normal(shape)) * 10.0 ** rng.integers(-14, 2, size=shape)
        zero = margins.record(values)
        assert np.array_equal(zero, values <= 1e-9)
        if zero.any():
            seen_zero = max(seen_zero, float(values[zero].max()))
        if not zero.all():
            seen_nonzero = min(seen_nonzero, float(values[~zero].min()))
        assert (margins.largest_zero, margins.smallest_nonzero) == (seen_zero, seen_nonzero)
    before = (margins.largest_zero, margins.smallest_nonzero)
    assert not margins.record(np.array([np.nan, 1e3])).any()  # NaN is not zero and moves nothing
    assert (margins.largest_zero, margins.smallest_nonzero) == before
    margins.record(np.array([np.nan, 2e-10, 5e-9]))
    assert margins.largest_zero == max(before[0], 2e-10) and margins.smallest_nonzero == min(before[1], 5e-9)
