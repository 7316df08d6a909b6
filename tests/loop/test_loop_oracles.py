"""The loop's exact operator against brute force: enumeration of arrival sequences, a full-vec float operator.

* Exact enumeration: every arrival sequence of a short horizon, each propagated by its own
  covariance recursion built from a plain step function of the loop equations (not from
  kfio's mode matrices), weighted by its exact probability, gives ``E[z_t z_t']`` exactly;
  kfio's reduced operator must give the same rationals.
* An independent float implementation of the second-moment operator: the full joint chain
  (no averaging of i.i.d. links), ``sum p_ij (M_i kron M_i)`` on ``vec``, and numpy's
  eigenvalues (Costa, Fragoso and Marques 2005, Ch. 3).
"""

from __future__ import annotations

import itertools
import random
from fractions import Fraction as F

import flint
import numpy as np
import pytest

from kfio.loop import parse_loop_request
from kfio.loop._mjls import link_of, loop_maps, loop_mjls, loop_state_size, mean_arrival
from kfio.loop._operator import second_moments, to_numpy
from kfio.loop._verdict import decide


def _t(x: F) -> str:
    return str(x.numerator) if x.denominator == 1 else f"{x.numerator}/{x.denominator}"


def _m(rows):
    return [[_t(F(x)) for x in row] for row in rows]


def _request(form, protocol, on_loss):
    return parse_loop_request(
        {
            "system": {
                "A": _m([[F(11, 10), F(1, 5)], [0, F(9, 10)]]),
                "B": _m([[0], [1]]),
                "C": _m([[1, 0], [0, 1]]),
                "Q": _m([[1, 0], [0, F(1, 2)]]),
                "R": _m([[F(1, 4), 0], [0, F(1, 3)]]),
                "sensors": [{"name": "pos", "rows": [0]}, {"name": "vel", "rows": [1]}],
            },
            "channel": {
                "model": "per_sensor",
                "channels": {
                    "pos": {"model": "bernoulli", "arrival_probability": "3/4"},
                    "vel": {"model": "gilbert_elliott", "failure_rate": "1/5", "recovery_rate": "1/2"},
                },
            },
            "actuator_channel": {"model": "gilbert_elliott", "failure_rate": "1/10", "recovery_rate": "2/3"},
            "controller": {
                "gains": {"feedback": _m([[F(1, 5), F(3, 5)]]), "estimator": _m([[F(1, 2), F(1, 10)], [0, F(2, 5)]])},
                "form": form,
            },
            "options": {"loop": {"protocol": protocol, "on_loss": on_loss}},
        }
    )


def _q(rows):
    return flint.fmpq_mat([[flint.fmpq(F(x).numerator, F(x).denominator) for x in row] for row in rows])


def _step(req, z, w, v, gamma, nu, nubar):
    """One step of the loop equations, written out plainly (the docstring of kfio.loop._model)."""
    A, B, C = _q(req.system.A), _q(req.B), _q(req.system.C)
    K, L = _q(req.K), _q(req.L)
    n, m = req.n, req.m
    col = lambda start, size: flint.fmpq_mat([[z[start + i, 0]] for i in range(size)])  # noqa: E731
    x, xh = col(0, n), col(n, n)
    a_prev = col(2 * n, m) if req.on_loss == "hold" else None
    y = C * x + v
    innov = flint.fmpq_mat([[gamma[i] * (y[i, 0] - (C * xh)[i, 0])] for i in range(req.p)])
    xf = xh + K * innov if req.form == "filter" else xh
    u = -(L * xf)
    a = u if nu else (a_prev if a_prev is not None else 0 * u)
    nb = flint.fmpq(nubar.numerator, nubar.denominator)
    if req.protocol == "tcp":
        ah = a
    elif a_prev is not None:
        ah = nb * u + (1 - nb) * col(2 * n + m, m)
    else:
        ah = nb * u
    x1 = A * x + B * a + w
    xh1 = A * xf + B * ah if req.form == "filter" else A * xh + B * ah + K * innov
    parts = [x1, xh1] + ([a] + ([ah] if req.protocol == "udp" else []) if a_prev is not None else [])
    return flint.fmpq_mat([[p[i, 0]] for p in parts for i in range(p.nrows())])


def _maps(req, gamma, nu, nubar):
    d, n, p = loop_state_size(req), req.n, req.p
    zero = lambda k: flint.fmpq_mat(k, 1)  # noqa: E731

    def unit(k, i):
        e = zero(k)
        e[i, 0] = 1
        return e

    M = [_step(req, unit(d, i), zero(n), zero(p), gamma, nu, nubar) for i in range(d)]
    G = [_step(req, zero(d), unit(n, i), zero(p), gamma, nu, nubar) for i in range(n)]
    G += [_step(req, zero(d), zero(n), unit(p, i), gamma, nu, nubar) for i in range(p)]
    as_mat = lambda cols: flint.fmpq_mat([[c[r, 0] for c in cols] for r in range(d)])  # noqa: E731
    return as_mat(M), as_mat(G)


@pytest.mark.parametrize(
    "form,protocol,on_loss",
    [("predictor", "tcp", "zero"), ("filter", "udp", "hold"), ("filter", "tcp", "hold"), ("predictor", "udp", "zero")],
)
def test_enumeration_of_arrival_sequences_matches_the_operator_exactly(form, protocol, on_loss):
    req = _request(form, protocol, on_loss)
    sys = loop_mjls(req)
    links = sys.links  # pos (Bernoulli), vel (Gilbert-Elliott), actuator (Gilbert-Elliott)
    nubar = mean_arrival(links[2]) if protocol == "udp" else F(1)
    d = loop_state_size(req)
    z0 = _q([[F(1), F(-2), F(1, 2), F(0)] + [F(1, 3)] * (d - 4)]).transpose()
    X0 = z0 * z0.transpose()
    Sigma = sys.Sigma
    h0 = {1: 1, 2: 0}  # initial histories of the Gilbert-Elliott links: vel arrived, actuator lost

    def prob(k, prev, g):
        ch = links[k].channel
        p1 = ch.table[0] if ch.order == 0 else ch.table[prev]
        return p1 if g else 1 - p1

    steps = 3
    expected = [X0]
    cache: dict = {}
    # prefixes: E[z_t z_t'] = sum over sequences of length t of P(seq) Cov_t(seq)
    for t in range(1, steps + 1):
        acc = flint.fmpq_mat(d, d)
        for seq in itertools.product(list(itertools.product((0, 1), repeat=3)), repeat=t):
            w = F(1)
            prev = {1: h0[1], 2: h0[2]}
            cov = X0
            for gp, gv, gn in seq:
                w *= prob(0, None, gp) * prob(1, prev[1], gv) * prob(2, prev[2], gn)
                prev = {1: gv, 2: gn}
                if (gp, gv, gn) not in cache:
                    cache[(gp, gv, gn)] = _maps(req, (gp, gv), gn, nubar)
                M, G = cache[(gp, gv, gn)]
                cov = M * cov * M.transpose() + G * Sigma * G.transpose()
            acc += flint.fmpq(w.numerator, w.denominator) * cov
        expected.append(acc)
    # kfio: reduced modes are the states (g_vel, g_act) of the links with memory, in that order
    first = {(gv, gn): prob(1, h0[1], gv) * prob(2, h0[2], gn) for gv in (0, 1) for gn in (0, 1)}
    dist0 = [first[(gv, gn)] for gv, gn in itertools.product((0, 1), (0, 1))]
    got = second_moments(sys, X0, dist0, steps)
    for t in range(steps + 1):
        assert got[t] == expected[t], t


def _full_vec_radius(req):
    """rho of sum_ij p_ij (M_i kron M_i) over the full joint chain, in floats, built independently."""
    sys = loop_mjls(req)
    links = [link_of(lk.label, lk.pointer, lk.channel) for lk in sys.links]
    nubar = mean_arrival(links[-1]) if req.protocol == "udp" else F(1)
    states = []
    for lk in links:
        if lk.channel.order == 0:
            lam = float(lk.channel.table[0])
            states.append(([0, 1], lambda i, j, lam=lam: lam if j else 1 - lam))
        else:
            tbl = [float(x) for x in lk.channel.table]
            states.append(([0, 1], lambda i, j, tbl=tbl: tbl[i] if j else 1 - tbl[i]))
    modes = list(itertools.product(*(s for s, _ in states)))
    d = loop_state_size(req)
    Ms = []
    for mode in modes:
        gamma = [0] * req.p
        for k, row in enumerate(req.system.sensors or []):
            for r in row.rows:
                gamma[r] = mode[k]
        if req.system.sensors is None:
            gamma = [mode[0]] * req.p
        M, _ = loop_maps(req, gamma, mode[-1], nubar)[:2]
        Ms.append(to_numpy(M))
    N = len(modes)
    T = np.zeros((N * d * d, N * d * d))
    for i, a in enumerate(modes):
        for j, b in enumerate(modes):
            p = np.prod([f(x, y) for (_, f), x, y in zip(states, a, b)])
            T[j * d * d : (j + 1) * d * d, i * d * d : (i + 1) * d * d] = p * np.kron(Ms[i], Ms[i])
    return float(np.max(np.abs(np.linalg.eigvals(T))))


def _random_request(rng: random.Random):
    r = lambda lo, hi, den=8: F(rng.randint(lo, hi), den)  # noqa: E731
    ch = lambda: (  # noqa: E731
        {"model": "bernoulli", "arrival_probability": _t(r(2, 7))}
        if rng.random() < 0.5
        else {"model": "gilbert_elliott", "failure_rate": _t(r(1, 6)), "recovery_rate": _t(r(2, 7))}
    )
    return parse_loop_request(
        {
            "system": {
                "A": _m([[r(4, 12), r(-3, 3)], [r(-3, 3), r(4, 12)]]),
                "B": _m([[r(0, 8)], [r(1, 8)]]),
                "C": _m([[r(4, 8), r(-2, 2)]]),
                "Q": _m([[1, 0], [0, 1]]),
                "R": _m([[1]]),
            },
            "channel": ch(),
            "actuator_channel": ch(),
            "controller": {
                "gains": {"feedback": _m([[r(-2, 8), r(0, 8)]]), "estimator": _m([[r(0, 8)], [r(-2, 4)]])},
                "form": rng.choice(["predictor", "filter"]),
            },
            "options": {"loop": {"protocol": rng.choice(["tcp", "udp"]), "on_loss": rng.choice(["zero", "hold"])}},
        }
    )


@pytest.mark.parametrize("seed", range(10))
def test_independent_full_vec_float_operator_agrees(seed):
    req = _random_request(random.Random(seed))
    dec = decide(loop_mjls(req))
    rho = _full_vec_radius(req)
    assert dec.spectral_radius == pytest.approx(rho, rel=1e-7, abs=1e-9)
    if abs(rho - 1) > 1e-6:
        assert dec.verdict == ("stable" if rho < 1 else "unstable")
