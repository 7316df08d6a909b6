"""The filtered covariance P(t|t) beside the predictor P(t|t-1): closed forms, exact enumeration, Monte Carlo."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest

from kfio import load_request
from kfio.simulation import expected_covariance, simulate
from kfio.simulation._filtered import filtered_covariance


def _request(A, C, lam, **sim):
    n, p = len(A), len(C)
    return load_request(
        json.dumps(
            {
                "system": {"A": A, "C": C, "Q": np.eye(n).tolist(), "R": np.eye(p).tolist()},
                "channel": {"model": "bernoulli", "arrival_probability": lam},
                "options": {"simulate": sim},
            }
        )
    )


def test_filtered_is_the_information_form_for_every_arrival_set():
    rng = np.random.default_rng(3)
    n, p = 3, 3
    B = rng.normal(size=(n, n))
    P = B @ B.T + np.eye(n)
    C = rng.normal(size=(p, n))
    R = np.diag([0.5, 1.0, 2.0])
    for bits in itertools.product((0.0, 1.0), repeat=p):
        rows = [i for i in range(p) if bits[i]]
        got = filtered_covariance(P[None], C, R, np.array([bits]))[0]
        if rows:
            info = np.linalg.inv(P) + C[rows].T @ np.linalg.inv(R[np.ix_(rows, rows)]) @ C[rows]
            want = np.linalg.inv(info)
        else:
            want = P
        np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-12)


def test_scalar_exact_filtered_mean_by_hand():
    # a = 2, lambda = 1/2, P0 = Q = R = 1: P_0 = 1 -> filtered 1/2 (1) + 1/2 (1/2) = 3/4;
    # P_1 in {5 (lost), 3 (arrived)}, each w.p. 1/2, filtered p -> p / (p + 1) when it arrives.
    rep = expected_covariance(_request([[2]], [[1]], 0.5), 2)
    f = rep.filtered_mean_trace
    assert f is not None
    want1 = 0.5 * (0.5 * 5 + 0.5 * 5 / 6) + 0.5 * (0.5 * 3 + 0.5 * 3 / 4)
    np.testing.assert_allclose(f[:2], [0.75, want1], rtol=1e-12)
    assert rep.to_dict()["filtered_mean_trace"][1] == pytest.approx(want1)


def test_scalar_enumeration_against_direct_sum():
    # independent route: every sequence of 0/1 arrivals, scalar Riccati by hand
    a, lam, T = 1.3, 0.6, 6
    rep = expected_covariance(_request([[a]], [[1]], lam), T)
    want = np.zeros(T + 1)
    for seq in itertools.product((0, 1), repeat=T + 1):
        w = float(np.prod([lam if g else 1 - lam for g in seq]))
        P = 1.0
        for t, g in enumerate(seq):
            filt = P / (P + 1) if g else P
            want[t] += w * filt
            P = a * a * filt + 1
    np.testing.assert_allclose(rep.filtered_mean_trace, want, rtol=1e-10)


def test_monte_carlo_filtered_mean_matches_exact_enumeration():
    A = [[1.1, 0.4], [0.0, 0.8]]
    C = [[1.0, 0.5]]
    T = 10
    req = _request(A, C, 0.7, steps=T, trajectories=20000, seed=11, exact_steps=T)
    rep = simulate(req)
    exact = rep.exact.filtered_mean_trace
    f = rep.filtered_stats
    z = np.abs(f.mean - exact) / f.sem
    assert (z[1:] <= 1.96).sum() >= 8, z  # about 95% of 10 steps inside the band
    assert z.max() < 4.0
    # the filtered covariance never exceeds the predictor, trajectory by trajectory, hence in the mean
    assert np.all(f.mean <= rep.stats.mean + 1e-12)
    d = rep.to_dict()
    assert d["filtered"]["mean_trace"][T] == pytest.approx(f.mean[T])
    assert d["filtered"]["final_mean_covariance"] is not None
    st = d["stationary"]
    for fq, pq in zip(st["filtered_quantiles"], st["quantiles"]):
        assert fq["trace"] <= pq["trace"]


def test_filtered_does_not_change_the_predictor_stream():
    # a predictor-only loop with the same generator, channel and kernel (what simulate did before P(t|t)):
    # the predictor statistics must be identical, so the filtered covariance draws nothing extra in between
    from kfio.simulation._channel import JointChannel
    from kfio.simulation._kernel import traces
    from kfio.simulation._packed import PackedRiccatiStep
    from kfio.simulation._setup import parse_options, sim_system

    req = _request([[1.2, 0.3], [0.0, 0.9]], [[1.0, 0.0]], 0.5, steps=30, trajectories=500, seed=4)
    rep = simulate(req)
    sim, opts = sim_system(req), parse_options(req)
    step = PackedRiccatiStep.build(sim.A, sim.Q, sim.C, sim.R)  # simulate's default kernel
    rng = np.random.Generator(np.random.PCG64(opts.seed))
    chan = JointChannel.from_packets(sim.packets)
    hist = chan.sample_initial(opts.initial_channel, opts.trajectories, rng)
    P = np.broadcast_to(opts.P0, (opts.trajectories, 2, 2)).copy()
    means = [traces(P).mean()]
    h = step.pack(P)
    for _ in range(opts.steps):
        g = rng.random((opts.trajectories, chan.m)) < chan.arrival_probability(hist)
        h, _ratio = step.apply_packed(h, g.astype(float))
        hist = chan.advance(hist, g)
        means.append(step.traces(h).mean())
    P = step.unpack(h)
    np.testing.assert_array_equal(rep.stats.mean, np.array(means))
    np.testing.assert_array_equal(rep.final_mean_covariance, P.mean(axis=0))
    assert np.all(rep.filtered_stats.mean < rep.stats.mean)
