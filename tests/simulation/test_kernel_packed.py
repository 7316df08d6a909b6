"""The structure-of-arrays kernel (``PackedRiccatiStep``) against the batched-matrix ``RiccatiStep``.

Same map, different arithmetic order: agreement to 1e-12 relative per step and over seeded runs,
identical divergence decisions, exactly symmetric output, and the fallback path for rows whose
innovation matrix lost definiteness.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from kfio import load_request
from kfio.simulation._kernel import RiccatiStep
from kfio.simulation._packed import PackedRiccatiStep
from kfio.simulation._setup import parse_options, sim_system
from kfio.simulation._simulate import run_monte_carlo


def random_case(rng, n, p, M):
    A = rng.normal(size=(n, n))
    C = rng.normal(size=(p, n))
    B = rng.normal(size=(n, n))
    Q = B @ B.T + np.eye(n)
    R = np.diag(rng.uniform(0.5, 2.0, p))
    X = rng.normal(size=(M, n, n))
    return A, C, Q, R, np.einsum("mij,mkj->mik", X, X)


@pytest.mark.parametrize(
    "n,p,rows", [(1, 1, 1), (3, 1, 1), (3, 2, 2), (4, 3, 3), (6, 2, 1), (9, 4, 4), (6, 5, 5), (7, 6, 1), (20, 1, 1)]
)
def test_packed_step_agrees_with_the_matrix_step(n, p, rows) -> None:
    rng = np.random.default_rng(10 * n + p)
    A, C, Q, R, P = random_case(rng, n, p, 500)
    mask = (rng.random((500, rows)) < 0.6).astype(float)
    for m in (None, mask):
        ref, r_ref = RiccatiStep.build(A, Q, C, R).apply(P, m)
        out, r_out = PackedRiccatiStep.build(A, Q, C, R).apply(P, m)
        scale = np.abs(ref).max(axis=(1, 2))[:, None, None]
        assert np.abs(out - ref).max() <= 1e-12 * scale.max()
        assert np.all(np.abs(out - ref) <= 1e-12 * scale)
        assert np.allclose(r_out, r_ref, rtol=1e-12, atol=0)
        assert np.array_equal(out, np.swapaxes(out, 1, 2))


def test_packed_step_falls_back_where_definiteness_was_lost() -> None:
    rng = np.random.default_rng(7)
    A, C, Q, R, P = random_case(rng, 3, 2, 50)
    P[:5] = -P[:5]  # C P C' + R indefinite in these rows: the reference path lifts S
    with np.errstate(invalid="ignore"):  # sqrt of the negative pivots, then the lift
        ref, _ = RiccatiStep.build(A, Q, C, R).apply(P)
        out, _ = PackedRiccatiStep.build(A, Q, C, R).apply(P)
    assert np.isfinite(out).all()
    assert np.allclose(out, ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())


@pytest.mark.parametrize("p", [2, 6])  # unrolled Cholesky (p <= 4) and LAPACK's batched one (p > 4)
def test_the_matrix_step_lifts_only_the_rows_that_lost_definiteness(p) -> None:
    # LAPACK refuses a whole batch when one S is indefinite; every other row must still be
    # computed as if alone (before, p > 4 lifted the S of every trajectory in the batch)
    rng = np.random.default_rng(74)
    A, C, Q, R, P = random_case(rng, 3, p, 12)
    P[7] = -P[7]
    step = RiccatiStep.build(A, Q, C, R)
    with np.errstate(invalid="ignore"):
        batch, _ = step.apply(P)
        alone = np.concatenate([step.apply(P[m : m + 1])[0] for m in range(12)])
    assert np.isfinite(batch).all()
    np.testing.assert_array_equal(np.delete(batch, 7, axis=0), np.delete(alone, 7, axis=0))
    assert np.allclose(batch[7], alone[7], rtol=1e-12, atol=0)


@pytest.mark.parametrize(
    "system,channel",
    [
        (
            {
                "A": [[1.25, 1, 0], [0, 0.9, 7], [0, 0, 0.6]],
                "C": [[1, 0, 2]],
                "Q": np.diag([20] * 3).tolist(),
                "R": [[2.5]],
            },
            {"model": "bernoulli", "arrival_probability": 0.6},
        ),
        (
            {
                "A": [[1.25, 0], [1, 1.1]],
                "C": [[1, 0], [1, 1]],
                "Q": [[20, 0], [0, 20]],
                "R": [[2.5, 0], [0, 2.5]],
                "sensors": [{"name": "one", "rows": [0]}, {"name": "two", "rows": [1]}],
            },
            {
                "model": "per_sensor",
                "channels": {
                    "one": {"model": "bernoulli", "arrival_probability": 0.5},
                    "two": {"model": "bernoulli", "arrival_probability": 0.3},
                },
            },
        ),
        (  # below the critical probability: trajectories diverge, the counts must match exactly
            {"A": [[-1.25]], "C": [[1]], "Q": [[1]], "R": [[2.5]]},
            {"model": "bernoulli", "arrival_probability": 0.1},
        ),
    ],
)
def test_seeded_runs_agree_across_kernels(system, channel) -> None:
    body = {
        "system": system,
        "channel": channel,
        "options": {"simulate": {"steps": 120, "trajectories": 3000, "seed": 5}},
    }
    req = load_request(json.dumps(body))
    sim, opts = sim_system(req), parse_options(req)
    a = run_monte_carlo(sim, opts, update=PackedRiccatiStep.build(sim.A, sim.Q, sim.C, sim.R))
    b = run_monte_carlo(sim, opts, update=RiccatiStep.build(sim.A, sim.Q, sim.C, sim.R))
    assert np.array_equal(a.stats.diverged, b.stats.diverged)
    assert np.array_equal(a.arrival_rate, b.arrival_rate)  # the random stream does not depend on the kernel
    ok = np.isfinite(b.stats.mean)
    assert np.array_equal(ok, np.isfinite(a.stats.mean))
    assert np.allclose(a.stats.mean[ok], b.stats.mean[ok], rtol=1e-12, atol=0)
    assert np.allclose(a.stats.percentiles, b.stats.percentiles, rtol=1e-12, atol=0, equal_nan=True)
    # the filtered P(t|t): trace P(t|t) from the packed step's own P - V'V, against the matrix kernel's update
    fa, fb = a.filtered_stats, b.filtered_stats
    assert fa is not None and fb is not None
    assert np.array_equal(np.isfinite(fa.mean), np.isfinite(fb.mean))
    okf = np.isfinite(fb.mean)
    assert np.allclose(fa.mean[okf], fb.mean[okf], rtol=1e-12, atol=0)
    assert np.allclose(fa.percentiles, fb.percentiles, rtol=1e-12, atol=0, equal_nan=True)
    # per trajectory, 120 steps of rounding go through the update's cancellation (eps x innovation ratio):
    # up to 1.4e-12 on the first system, as between the two kernels before this one
    assert np.allclose(a.final_traces, b.final_traces, rtol=1e-12, atol=0)
    assert np.allclose(a.final_filtered_traces, b.final_filtered_traces, rtol=1e-11, atol=0)


def test_the_kernel_s_congruence_matrix_is_the_bounds_one() -> None:
    from kfio.riccati_bounds._vech import congruence_matrix
    from kfio.simulation._kernel import _congruence

    A = np.random.default_rng(3).normal(size=(5, 5))
    assert np.array_equal(_congruence(A), congruence_matrix(A))


@pytest.mark.parametrize("n,p,rows", [(2, 1, 1), (3, 2, 2), (5, 3, 1), (12, 2, 2), (20, 1, 1)])
def test_blocked_advance_agrees_with_the_matrix_kernel(monkeypatch, n, p, rows) -> None:
    """Many blocks (one short), the outcome arrays and the filtered trace, against ``RiccatiStep.update``/``apply``."""
    import kfio.simulation._packed as packed

    monkeypatch.setattr(packed, "BLOCK_MIN", 64)
    monkeypatch.setattr(packed, "BLOCK_MAX", 64)
    monkeypatch.setattr(packed, "BLOCK_PER_ROW", 0)
    rng = np.random.default_rng(n + 7 * p)
    M = 64 * 3 + 17
    A, C, Q, R, P = random_case(rng, n, p, M)
    mask = (rng.random((M, rows)) < 0.5).astype(float)
    step = PackedRiccatiStep.build(A, Q, C, R)
    work = step.workspace(M)
    assert work.B == 64
    ref = RiccatiStep.build(A, Q, C, R)
    for m in (None, mask):
        post, r_ref = ref.update(P, m)
        nxt = ref.open_loop(post)
        h = step.pack(P)
        out = step.advance(h, m, work)
        got = step.unpack(h)
        scale = np.abs(nxt).max(axis=(1, 2))[:, None, None]
        assert np.all(np.abs(got - nxt) <= 1e-12 * scale)
        assert np.allclose(out.ratio, r_ref, rtol=1e-12, atol=0)
        assert np.allclose(out.trace, np.einsum("mii->m", nxt), rtol=1e-12, atol=0)
        ftr = np.einsum("mii->m", post)
        assert np.all(np.abs(out.filtered_trace - ftr) <= 1e-12 * np.einsum("mii->m", P))
        assert out.finite.all()
        fil = step.unpack(step.update_packed(step.pack(P), m))
        assert np.all(np.abs(fil - post) <= 1e-12 * np.abs(P).max(axis=(1, 2))[:, None, None])


def test_the_filtered_update_is_the_information_form() -> None:
    """``P - V'V`` of the packed kernel against ``(P^-1 + C_S' R_SS^-1 C_S)^-1`` per arrival set (independent route)."""
    rng = np.random.default_rng(12)
    n, p, M = 4, 3, 8
    A, C, Q, R, P = random_case(rng, n, p, M)
    P += np.eye(n)
    step = PackedRiccatiStep.build(A, Q, C, R)
    for bits in np.ndindex(*(2,) * p):
        mask = np.broadcast_to(np.array(bits, float), (M, p)).copy()
        got = step.unpack(step.update_packed(step.pack(P), mask))
        rows = [i for i in range(p) if bits[i]]
        for m in range(M):
            info = np.linalg.inv(P[m]) + C[rows].T @ np.linalg.inv(R[np.ix_(rows, rows)]) @ C[rows]
            np.testing.assert_allclose(got[m], np.linalg.inv(info), rtol=1e-10, atol=1e-12)


def test_advance_flags_non_finite_columns_and_sends_lost_definiteness_to_the_reference(monkeypatch) -> None:
    import kfio.simulation._packed as packed

    monkeypatch.setattr(packed, "BLOCK_MIN", 16)
    monkeypatch.setattr(packed, "BLOCK_MAX", 16)
    monkeypatch.setattr(packed, "BLOCK_PER_ROW", 0)
    rng = np.random.default_rng(8)
    A, C, Q, R, P = random_case(rng, 3, 2, 70)
    indefinite = [3, 20, 21, 69]  # C P C' + R indefinite: the matrix kernel lifts S
    P[indefinite] = -P[indefinite]
    P[40, 0, 1] = P[40, 1, 0] = np.inf  # non-finite input
    step = PackedRiccatiStep.build(A, Q, C, R)
    h = step.pack(P)
    with np.errstate(all="ignore"):
        out = step.advance(h, None, step.workspace(70))
        post, ratio = RiccatiStep.build(A, Q, C, R).update(P[indefinite])
    assert np.flatnonzero(~out.finite).tolist() == [40]
    want = RiccatiStep.build(A, Q, C, R).open_loop(post)
    got = step.unpack(h)[indefinite]
    assert np.allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())
    assert np.allclose(out.filtered_trace[indefinite], np.einsum("mii->m", post), rtol=1e-12, atol=0)
    assert np.allclose(out.ratio[indefinite], ratio, rtol=1e-12, atol=0)


def test_no_measured_rows_is_the_open_loop() -> None:
    rng = np.random.default_rng(2)
    A, C, Q, R, P = random_case(rng, 3, 1, 40)
    step = PackedRiccatiStep.build(A, Q, np.zeros((0, 3)), np.zeros((0, 0)))
    h = step.pack(P)
    out = step.advance(h)
    want = RiccatiStep.build(A, Q, np.zeros((0, 3)), np.zeros((0, 0))).open_loop(P)
    assert np.allclose(step.unpack(h), want, rtol=1e-12, atol=1e-12 * np.abs(want).max())
    assert np.array_equal(out.filtered_trace, step.traces(step.pack(P)))
    assert not out.ratio.any()
