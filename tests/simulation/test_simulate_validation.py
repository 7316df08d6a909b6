"""Validation of the exact verdict by the exact finite-horizon mean.

When ``analyze`` says ``unstable``, ``trace E[P_t]`` (Rohr, Marelli and Fu (2014), eq. (7), computed by enumeration)
must grow like ``rate^t`` with ``rate`` the largest block ``|alpha_k|^2 sigma_k``; when it says
``stable``, it must level off.  Cases: the seed systems of docs/theory.md on both sides of their
thresholds, and random small systems (fixed seed) chosen away from the boundary.

Tolerance.  ``trace E[P_t] = c t^k rate^t (1 + O(r^t))`` where ``r < 1`` is the ratio of the next
growth term to the largest and ``k`` the polynomial order (0 here: no Jordan blocks in these
classes).  The log-slope over the last 6 of 20 steps therefore estimates ``log rate`` to
``O(r^14)``; on these cases the error is below 0.04, and we allow ``GROWTH_TOL = 0.06``.  Cases are
chosen with ``rate >= 1.25`` or ``rate <= 0.7``, so "stable" (growth 1) and "unstable" are at least
0.2 apart in log.  Two packets square the number of sequences, so that case uses 10 steps and a
4-step window (its second growth term is 0.54 of the first, so the error is still < 0.01).
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest

from kfio.model._types import Request
from kfio.simulation._finite_horizon import expected_covariance

from support.factories import bern, ge, make

GROWTH_TOL = 0.06
LEVELS_OFF = 1.05  # per-step growth at the end of the horizon that counts as levelled off


def verdict(req: Request) -> tuple[str, float]:
    """``analyze``'s verdict and its largest block rate (0 when no block has one)."""
    from kfio import analyze

    rep = analyze(req)
    rates = [b.rate for b in rep.blocks if b.rate is not None]
    return rep.verdict, max(rates, default=0.0)


def check_growth(req: Request, horizon: int = 20, window: int = 6) -> tuple[str, float]:
    v, rate = verdict(req)
    assert v in ("stable", "unstable"), "validation cases are chosen away from the boundary"
    rep = expected_covariance(req, horizon)
    g = rep.growth_per_step(window)
    # Sequences whose update lost more than 12 digits are flagged "imprecise" but kept; their
    # total probability must stay negligible (tests/test_finite_horizon.py shows the mean is
    # still accurate to 1e-9 against exact rational arithmetic in such cases).
    assert g is not None and rep.imprecise_probability[-1] < 1e-4
    if v == "unstable":
        assert rate > 1
        assert abs(math.log(g) - math.log(rate)) < GROWTH_TOL, (g, rate)
    else:
        assert rate < 1
        assert g < LEVELS_OFF, g
    return v, rate


SCALAR = {"A": [[-1.25]], "C": [[1]], "Q": [[1]], "R": [[2.5]]}
SEED004 = {
    "A": [[1.25, 1, 0], [0, 0.9, 7], [0, 0, 0.6]],
    "C": [[1, 0, 2]],
    "Q": [[20, 0, 0], [0, 20, 0], [0, 0, 20]],
    "R": [[2.5]],
}
SEED004_2X2 = {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]], "Q": [[20, 0], [0, 20]], "R": [[2.5]]}
SQRT3 = "1.7320508075688772935274463"
EXAMPLE1 = {"A": [[2, 0], [0, -2]], "C": [[1, 1]], "Q": [[1, 0], [0, 1]], "R": [[1]]}
EXAMPLE1_GE = {"A": [[SQRT3, 0], [0, "-" + SQRT3]], "C": [[1, 1]], "Q": [[1, 0], [0, 1]], "R": [[1]]}

SEED_CASES = {
    # name: (system, channel, expected verdict, rate from the seeds' closed forms)
    "scalar_lambda_0.2": (SCALAR, bern(0.2), "unstable", 1.5625 * 0.8),  # Sinopoli et al. (2004), Fig. 1
    "scalar_lambda_0.6": (SCALAR, bern(0.6), "stable", 1.5625 * 0.4),
    "seed004_lambda_0.1": (SEED004, bern(0.1), "unstable", 1.5625 * 0.9),  # Sinopoli et al. (2004), Fig. 2
    "seed004_lambda_0.6": (SEED004, bern(0.6), "stable", 1.5625 * 0.4),
    "seed004_2x2_lambda_0.1": (SEED004_2X2, bern(0.1), "unstable", 1.5625 * 0.9),  # Sinopoli et al. (2004), Fig. 3
    "seed004_2x2_lambda_0.7": (SEED004_2X2, bern(0.7), "stable", 1.5625 * 0.3),
    # Rohr, Marelli and Fu (2014), Example 3: degenerate, sigma = (1 - lambda)^(1/2)
    "example1_bernoulli_0.8": (EXAMPLE1, bern(0.8), "unstable", 4 * math.sqrt(0.2)),
    "example1_bernoulli_0.97": (EXAMPLE1, bern(0.97), "stable", 4 * math.sqrt(0.03)),
    # Rohr, Marelli and Fu (2014), Example 2 as corrected in test_finite_horizon: sigma^2 = (1 - q)^2 + p q
    "example1_ge_unstable": (EXAMPLE1_GE, ge(0.05, 0.5), "unstable", 3 * math.sqrt(0.25 + 0.025)),
    "example1_ge_stable": (EXAMPLE1_GE, ge(0.05, 0.9), "stable", 3 * math.sqrt(0.01 + 0.045)),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(SEED_CASES))
def test_seed_systems_growth_matches_verdict(name: str) -> None:
    system, channel, expected, closed_form = SEED_CASES[name]
    v, rate = check_growth(make(system, channel))
    assert v == expected
    if v == "unstable":
        assert rate == pytest.approx(closed_form, rel=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize(("lam1", "expected"), [(0.9, "stable"), (0.8, "unstable")])
def test_two_packets_growth_matches_verdict(lam1: float, expected: str) -> None:
    """docs/theory.md: A = diag(2.5, 1.5), one packet per state; exact region lambda_1 > 0.84, lambda_2 > 5/9."""
    system = {
        "A": [[2.5, 0], [0, 1.5]],
        "C": [[1, 0], [0, 1]],
        "Q": [[1, 0], [0, 1]],
        "R": [[1, 0], [0, 1]],
        "sensors": [{"name": "s1", "rows": [0]}, {"name": "s2", "rows": [1]}],
    }
    req = make(system, {"model": "per_sensor", "channels": {"s1": bern(lam1), "s2": bern(0.7)}})
    v, rate = check_growth(req, horizon=10, window=4)
    assert v == expected
    if v == "unstable":
        assert rate == pytest.approx(6.25 * (1 - lam1), rel=1e-9)


def _random_channel(rng: np.random.Generator, kind: int) -> dict:
    def r() -> str:
        return str(Fraction(int(rng.integers(1, 20)), 20))

    if kind == 0:
        return bern(r())
    if kind == 1:
        return ge(r(), r())
    return {"model": "markov", "order": 2, "arrival_probability": {h: r() for h in ("00", "01", "10", "11")}}


def _loss_after_losses(ch: dict) -> float:
    """P(g = 0 | nu zeros): sigma of a non-degenerate block (Rohr, Marelli and Fu (2014), Lemma 2)."""
    if ch["model"] == "bernoulli":
        return 1 - float(Fraction(ch["arrival_probability"]))
    if ch["model"] == "gilbert_elliott":
        return 1 - float(Fraction(ch["recovery_rate"]))
    return 1 - float(Fraction(ch["arrival_probability"]["00"]))


def random_cases(count: int = 12, seed: int = 2024) -> list[tuple[dict, dict, float]]:
    """Small systems with real eigenvalues of distinct moduli, every mode observed.

    Then every FMO block is one eigenvalue and non-degenerate, so the closed form
    ``rate = max |theta|^2 P(g = 0 | nu zeros)`` holds (Rohr, Marelli and Fu (2014), Theorem 1 with Lemma 2).
    Alternate unstable (1.3 < rate < 3) and stable (rate < 0.7) cases, channels of order 0, 1, 2.
    """
    rng = np.random.default_rng(seed)
    out: list[tuple[dict, dict, float]] = []
    while len(out) < count:
        n = 2 if len(out) < 8 else 3
        A = rng.integers(-8, 9, size=(n, n)) / 4
        C = rng.integers(-2, 3, size=(1, n))
        ev, V = np.linalg.eig(A)
        if np.any(np.abs(ev.imag) > 1e-12):
            continue
        mod = np.sort(np.abs(ev.real))[::-1]
        if mod[0] < 1.05 or mod[1] ** 2 > 0.7 * mod[0] ** 2 or np.min(np.abs(C @ V)) < 0.2:
            continue
        ch = _random_channel(rng, len(out) % 3)
        rate = float(mod[0] ** 2 * _loss_after_losses(ch))
        if not ((1.3 < rate < 3) if len(out) % 2 == 0 else rate < 0.7):
            continue
        system = {
            "A": [[str(Fraction(float(x)).limit_denominator(4)) for x in row] for row in A],
            "C": C.tolist(),
            "Q": np.eye(n, dtype=int).tolist(),
            "R": [[1]],
        }
        out.append((system, ch, rate))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("case", random_cases(), ids=lambda c: f"{len(c[0]['A'])}x{len(c[0]['A'])}-{c[1]['model']}")
def test_random_systems_growth_matches_verdict(case: tuple[dict, dict, float]) -> None:
    system, channel, closed_form = case
    v, rate = check_growth(make(system, channel), horizon=18)
    assert v == ("unstable" if closed_form > 1 else "stable")
    if v == "unstable":
        assert rate == pytest.approx(closed_form, rel=1e-9)
