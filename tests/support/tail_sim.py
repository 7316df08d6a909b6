"""Independent sampler of the stationary error covariance, for tail tests.

Shares nothing with :mod:`kfio.simulation`: many independent chains of the
one-step predictor Riccati recursion (Sinopoli et al. 2004, eq. (4))

    P <- A P A' + Q - g A P C' (C P C' + R)^-1 C P A'

run side by side in numpy, with i.i.d. or Gilbert-Elliott arrivals ``g``.
After a burn-in every chain is (approximately) stationary, because ``P_t``
converges in distribution for any arrival rate above 0 (Kar, Sinopoli and
Moura, 2012); the last ``keep`` steps of every chain are returned.
"""

from __future__ import annotations

import numpy as np


def stationary_traces(
    A, C, *, p_loss_after_arrival, q_recover, steps=400, keep=200, chains=20000, seed=0, Q=None, R=None
) -> np.ndarray:
    """``trace P`` of ``chains`` chains at the last ``keep`` of ``steps`` steps (flattened).

    The channel is Gilbert-Elliott with failure rate ``p_loss_after_arrival``
    and recovery rate ``q_recover``; Bernoulli ``lambda`` is ``p = 1 - lambda,
    q = lambda``.
    """
    A = np.atleast_2d(np.asarray(A, dtype=float))
    C = np.atleast_2d(np.asarray(C, dtype=float))
    n = A.shape[0]
    Q = np.eye(n) if Q is None else np.asarray(Q, dtype=float)
    R = np.eye(C.shape[0]) if R is None else np.asarray(R, dtype=float)
    rng = np.random.default_rng(seed)
    P = np.broadcast_to(np.eye(n), (chains, n, n)).copy()
    arrived = rng.random(chains) < 0.5
    out = []
    for t in range(steps):
        u = rng.random(chains)
        arrived = np.where(arrived, u >= p_loss_after_arrival, u < q_recover)
        APA = A @ P @ A.T + Q
        AP = A @ P
        S = C @ P @ C.T + R
        K = AP @ C.T @ np.linalg.inv(S)
        upd = APA - K @ (C @ P @ A.T)
        P = np.where(arrived[:, None, None], upd, APA)
        P = 0.5 * (P + np.swapaxes(P, 1, 2))
        if t >= steps - keep:
            out.append(np.trace(P, axis1=1, axis2=2))
    return np.concatenate(out)


def survival_slope(traces: np.ndarray, m1: float, m2: float) -> float:
    """``log(S(m1) / S(m2)) / log(m2 / m1)`` with ``S(m) = P(trace P > m)`` empirical."""
    s1 = float((traces > m1).mean())
    s2 = float((traces > m2).mean())
    return float(np.log(s1 / s2) / np.log(m2 / m1))
