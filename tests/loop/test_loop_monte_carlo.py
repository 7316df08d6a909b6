"""Monte Carlo of the closed loop over a long horizon against the exact stationary cost.

The loop is simulated from its equations (Schenato, Sinopoli, Franceschetti, Poolla and Sastry
2007, Sec. II) in numpy, independent trajectories in parallel; the time average of the stage
cost over the second half of each trajectory is one sample, and the exact cost of kfio.loop
must lie within the samples' 99.99% confidence interval (seeded: the same draw every run).
"""

from __future__ import annotations

import numpy as np
import pytest

import kfio


def _simulate(a, b, c, q, r, k, L, lam, nu, w, u_weight, form, protocol, on_loss, rng, trajectories=4000, steps=400):
    x = np.zeros(trajectories)
    xh = np.zeros(trajectories)
    held = np.zeros(trajectories)
    belief = np.zeros(trajectories)
    total = np.zeros(trajectories)
    for t in range(steps):
        g = rng.random(trajectories) < lam
        h = rng.random(trajectories) < nu
        y = c * x + np.sqrt(r) * rng.standard_normal(trajectories)
        innov = np.where(g, y - c * xh, 0.0)
        xf = xh + k * innov if form == "filter" else xh
        u = -L * xf
        applied = np.where(h, u, held if on_loss == "hold" else 0.0)
        if protocol == "tcp":
            seen = applied
        elif on_loss == "hold":
            seen = nu * u + (1 - nu) * belief
        else:
            seen = nu * u
        if t >= steps // 2:
            total += w * x**2 + u_weight * applied**2
        x_next = a * x + b * applied + np.sqrt(q) * rng.standard_normal(trajectories)
        xh = a * xf + b * seen if form == "filter" else a * xh + b * seen + k * innov
        x, held, belief = x_next, applied, seen
    return total / (steps - steps // 2)


@pytest.mark.parametrize("form,protocol,on_loss", [("predictor", "tcp", "zero"), ("filter", "udp", "hold")])
def test_monte_carlo_cost_within_its_confidence_interval_of_the_exact_cost(form, protocol, on_loss):
    a, b, c, q, r, k, L, lam, nu = 1.25, 1.0, 1.0, 1.0, 0.5, 0.5, 0.6, 0.8, 0.9
    sys = kfio.System(A=[[a]], C=[[c]], Q=[[q]], R=[[r]])
    rep = kfio.loop(
        sys,
        feedback=[[L]],
        estimator=[[k]],
        form=form,
        channel=kfio.bernoulli(lam),
        actuator_channel=kfio.bernoulli(nu),
        B=[[b]],
        cost={"W": [[1]], "U": [["1/2"]]},
        options={"protocol": protocol, "on_loss": on_loss},
    )
    assert rep.verdict == "stable"
    samples = _simulate(a, b, c, q, r, k, L, lam, nu, 1.0, 0.5, form, protocol, on_loss, np.random.default_rng(7))
    mean, se = samples.mean(), samples.std(ddof=1) / np.sqrt(samples.size)
    assert abs(mean - float(rep.cost)) < 3.9 * se, (mean, se, float(rep.cost))
    assert se < 0.05 * float(rep.cost)  # the interval is tight enough to mean something
