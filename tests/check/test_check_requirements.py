"""Each requirement is judged on the right number, cross-checked against brute force and closed forms.

The measured values of ``kfio check`` are read off kfio's reports; here they are
recomputed independently: the critical probability and worst rate from the
eigenvalues (Sinopoli et al. 2004; Rohr, Marelli and Fu 2014, Theorem 1 for a
non-degenerate block: ``rate = |alpha|^2 (1 - lambda)``), ``V_bar`` by iterating the
modified Riccati map to its fixed point, the tail exponent from Mo and Sinopoli
(2012), the outage probability by an independent Monte Carlo sampler.  Limits set
exactly at the measured rational show that comparisons are exact, not floating point.
"""

from __future__ import annotations

import json
import math
from fractions import Fraction

import numpy as np
import pytest

from kfio.check import parse_check, run_check

from support.check_layout import EXAMPLE
from support.tail_sim import stationary_traces

PLANTS = {
    name: json.loads((EXAMPLE / "plants" / f"{name}.json").read_text())["system"] for name in ("two_state", "scalar")
}
LAMBDA = Fraction(str(json.loads((EXAMPLE / "channels" / "radio.json").read_text())["channel"]["arrival_probability"]))


def judged(plant: str, requirements: dict, **opts) -> dict:
    spec = parse_check(
        {"checks": [{"plant": f"plants/{plant}.json", "channel": "channels/radio.json", "requirements": requirements}]},
        EXAMPLE,
    )
    return {o.requirement: o for o in run_check(spec, workers=1, **opts).outcomes}


def spectral_radius_sq(system) -> Fraction:
    A = np.array(system["A"], dtype=float)
    rho = max(abs(np.linalg.eigvals(A)))
    # the plants' eigenvalues are the diagonal entries of triangular A: exact rationals
    exact = max(Fraction(str(abs(system["A"][i][i]))) for i in range(len(A)))
    assert math.isclose(rho, float(exact))
    return exact**2


@pytest.mark.parametrize("plant", sorted(PLANTS))
def test_critical_probability_and_worst_rate_against_the_closed_forms(plant):
    r2 = spectral_radius_sq(PLANTS[plant])
    critical, rate = 1 - 1 / r2, r2 * (1 - LAMBDA)
    out = judged(plant, {"critical_arrival_probability_at_most": str(critical), "margin": str(1 - rate)})
    # both limits sit exactly on the measured value: <= holds with equality, exactly
    assert out["critical_arrival_probability_at_most"].status == "pass"
    assert Fraction(out["critical_arrival_probability_at_most"].measured) == critical
    assert out["margin"].status == "pass" and out["margin"].measured == f"worst rate {rate}"
    # one part in 10^12 tighter fails: a float comparison could not tell these apart
    tighter = judged(
        plant,
        {
            "critical_arrival_probability_at_most": str(critical * (1 - Fraction(1, 10**12))),
            "margin": str((1 - rate) * (1 + Fraction(1, 10**12))),
        },
    )
    assert {o.status for o in tighter.values()} == {"fail"}


def v_bar_trace(system, lam: float) -> float:
    """The fixed point of the modified Riccati map, iterated from 0 (Sinopoli et al. 2004, Theorem 6)."""
    A, C = (np.array(system[k], dtype=float) for k in ("A", "C"))
    Q, R = (np.array(system[k], dtype=float) for k in ("Q", "R"))
    X = np.zeros_like(A)
    for _ in range(20000):
        K = A @ X @ C.T @ np.linalg.inv(C @ X @ C.T + R)
        X = A @ X @ A.T + Q - lam * K @ C @ X @ A.T
    return float(np.trace(X))


@pytest.mark.slow
@pytest.mark.parametrize("plant", sorted(PLANTS))
def test_trace_v_bar_against_the_riccati_iteration(plant):
    brute = v_bar_trace(PLANTS[plant], float(LAMBDA))
    out = judged(plant, {"trace_V_bar_at_most": repr(brute * (1 + 1e-4))})["trace_V_bar_at_most"]
    assert out.status == "pass" and math.isclose(float(out.measured), brute, rel_tol=1e-5)
    below = judged(plant, {"trace_V_bar_at_most": repr(brute * (1 - 1e-4))})["trace_V_bar_at_most"]
    assert below.status == "fail"


def test_tail_exponent_against_mo_and_sinopoli():
    # non-degenerate block, Bernoulli: kappa = log(1 / (1 - lambda)) / log(|alpha|^2)
    r2 = spectral_radius_sq(PLANTS["two_state"])
    kappa = math.log(1 / (1 - LAMBDA)) / math.log(r2)
    out = judged("two_state", {"tail_exponent_above": repr(kappa * 0.999)})["tail_exponent_above"]
    assert out.status == "pass" and math.isclose(float(out.measured.split()[0]), kappa, rel_tol=1e-5)
    assert judged("two_state", {"tail_exponent_above": repr(kappa * 1.001)})["tail_exponent_above"].status == "fail"


def test_outage_against_an_independent_sampler():
    M, n = 10, 5000
    out = judged("scalar", {"outage": {"threshold": M, "epsilon": "0.99", "trajectories": n, "steps": 200}})["outage"]
    p_kfio = float(out.measured.split()[0])
    s = PLANTS["scalar"]
    lam = float(LAMBDA)
    traces = stationary_traces(
        s["A"],
        s["C"],
        p_loss_after_arrival=1 - lam,
        q_recover=lam,
        steps=200,
        keep=1,
        chains=n,
        seed=7,
        Q=s["Q"],
        R=s["R"],
    )
    p_brute = float(np.mean(traces > M))
    assert 0.01 < p_brute < 0.5  # the threshold is informative
    assert abs(p_kfio - p_brute) <= 5 * math.sqrt(p_brute * (1 - p_brute) * 2 / n)
    # the judgement is on the upper end of the 95% interval: an epsilon between the estimate and that end fails
    hi = float(out.measured.split("[")[1].split(",")[1].rstrip("]"))
    between = judged(
        "scalar", {"outage": {"threshold": M, "epsilon": repr((p_kfio + hi) / 2), "trajectories": n, "steps": 200}}
    )["outage"]
    assert between.status == "fail"


def test_verdict_requirement_reads_the_exact_verdict():
    assert judged("scalar", {"verdict": "stable"})["verdict"].status == "pass"
    assert judged("scalar", {"verdict": "unstable"})["verdict"].status == "fail"
