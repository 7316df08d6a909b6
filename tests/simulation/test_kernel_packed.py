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


@pytest.mark.parametrize("n,p,rows", [(1, 1, 1), (3, 1, 1), (3, 2, 2), (4, 3, 3), (6, 2, 1), (9, 4, 4)])
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


def test_the_kernel_s_congruence_matrix_is_the_bounds_one() -> None:
    from kfio.mare._vech import congruence_matrix
    from kfio.simulation._kernel import _congruence

    A = np.random.default_rng(3).normal(size=(5, 5))
    assert np.array_equal(_congruence(A), congruence_matrix(A))
