"""Scalar closed forms of loops over lossy links, asserted exactly against kfio.loop.

Fixed-gain estimator over i.i.d. arrivals ``lam``: ``e+ = (a - gamma k c) e + w - gamma k v``, so
``E e^2`` follows ``s+ = (lam (a - k c)^2 + (1 - lam) a^2) s + q + lam k^2 r``: stable iff the
factor is below 1, stationary ``(q + lam k^2 r) / (1 - factor)``.  Control over an actuator
link ``nu`` with the dead-beat gain ``L = a / b``: ``x+`` has factor ``(1 - nu) a^2``, so the
critical value is ``1 - 1/a^2`` (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007,
Sec. V, the TCP-like critical value for scalar systems), and no gain does better.
"""

from __future__ import annotations

import random
from fractions import Fraction as F

import pytest

from kfio.loop import analyze_loop, parse_loop_request
from kfio.loop._cost import stationary_cost
from kfio.loop._mjls import estimator_mjls
from kfio.loop._verdict import decide


def _text(x: F) -> str:
    return str(x.numerator) if x.denominator == 1 else f"{x.numerator}/{x.denominator}"


def _request(a, b, c, q, r, k, L, lam, nu, form="predictor"):
    return parse_loop_request(
        {
            "system": {"A": [[_text(a)]], "B": [[_text(b)]], "C": [[_text(c)]], "Q": [[_text(q)]], "R": [[_text(r)]]},
            "channel": {"model": "bernoulli", "arrival_probability": _text(lam)},
            "actuator_channel": {"model": "bernoulli", "arrival_probability": _text(nu)},
            "controller": {"gains": {"feedback": [[_text(L)]], "estimator": [[_text(k)]]}, "form": form},
        }
    )


def _random_case(rng: random.Random):
    a = F(rng.randint(-30, 30), 16)
    c = F(rng.choice([-2, -1, 1, 2, 3]), rng.choice([1, 2]))
    k = F(rng.randint(-20, 20), 16)
    lam = F(rng.randint(1, 19), 20)
    q, r = F(rng.randint(0, 9), 4), F(rng.randint(1, 9), 4)
    return a, c, k, lam, q, r


@pytest.mark.parametrize("seed", range(12))
def test_fixed_gain_estimator_closed_form(seed):
    rng = random.Random(seed)
    a, c, k, lam, q, r = _random_case(rng)
    req = _request(a, F(1), c, q, r, k, F(0), lam, F(1, 2))
    factor = lam * (a - k * c) ** 2 + (1 - lam) * a**2
    sys = estimator_mjls(req)
    dec = decide(sys)
    expected = "stable" if factor < 1 else ("boundary" if factor == 1 else "unstable")
    assert dec.verdict == expected
    assert dec.spectral_radius_exact == _text(factor)
    if factor < 1:
        assert stationary_cost(sys, dec.moments) == (q + lam * k**2 * r) / (1 - factor)
    else:
        assert dec.moments is None


def test_fixed_gain_estimator_boundary_is_exact():
    # lam (a - k c)^2 + (1 - lam) a^2 = 1 exactly: a = 5/4, k c = 1/2, lam = 9/16
    req = _request(F(5, 4), F(1), F(1), F(1), F(1), F(1, 2), F(0), F(9, 16), F(1, 2))
    dec = decide(estimator_mjls(req))
    assert (dec.verdict, dec.spectral_radius_exact) == ("boundary", "1")


def test_estimator_alone_critical_value_and_optimal_filter_beside_it():
    a, k = F(5, 4), F(1, 2)
    rep = _request(a, F(1), F(1), F(1), F(1), k, F(3, 5), F(4, 5), F(9, 10))
    out = analyze_loop(rep).to_dict()["estimator_alone"]
    # lam ((a - k)^2 - a^2) = 1 - a^2
    lam_c = (1 - a**2) / ((a - k) ** 2 - a**2)
    assert out["critical_sensor_arrival_probability_exact"] == _text(lam_c)
    assert out["optimal_filter_critical_arrival_probability_exact"] == _text(1 - 1 / a**2)
    assert (
        out["statement"]
        == f"the optimal time-varying filter needs {_text(1 - 1 / a**2)}; your steady-state gain needs {_text(lam_c)}"
    )


@pytest.mark.parametrize("a", [F(5, 4), F(2), F(-3, 2)])
def test_tcp_like_control_critical_value_one_minus_inverse_a_squared(a):
    b = F(2)
    # perfect sensor link, dead-beat predictor K = a / c: the error vanishes in one step
    req = _request(a, b, F(1), F(1), F(1), a, a / b, F(1), F(1, 2))
    rep = analyze_loop(req)
    assert rep.actuator_critical is not None
    assert rep.actuator_critical.exact == _text(1 - 1 / a**2)


@pytest.mark.parametrize("L", [F(1, 2), F(3, 4), F(3, 2)])
def test_no_fixed_control_gain_beats_one_minus_inverse_a_squared(L):
    a, b = F(5, 4), F(1)
    req = _request(a, b, F(1), F(1), F(1), a, L, F(1), F(1, 2))
    rep = analyze_loop(req)
    nu_c = (1 - a**2) / ((a - b * L) ** 2 - a**2)  # nu (a - b L)^2 + (1 - nu) a^2 = 1
    assert rep.actuator_critical.exact == _text(nu_c)
    assert nu_c > 1 - 1 / a**2


def test_the_cheap_rounded_certificate_verifies_stable_loops_only():
    from kfio.loop._mjls import loop_mjls
    from kfio.loop._verdict import rounded_certificate

    stable = _request(F(5, 4), F(1), F(1), F(1), F(1), F(1, 2), F(3, 5), F(4, 5), F(9, 10))
    unstable = _request(F(5, 4), F(1), F(1), F(1), F(1), F(1, 2), F(3, 5), F(1, 2), F(9, 10))
    assert decide(loop_mjls(stable)).verdict == "stable" and rounded_certificate(loop_mjls(stable))
    assert decide(loop_mjls(unstable)).verdict == "unstable" and not rounded_certificate(loop_mjls(unstable))


def test_an_operator_too_large_is_refused_naming_the_field():
    from kfio.errors import LimitExceeded

    n = 12
    eye = [["1" if i == j else "0" for j in range(n)] for i in range(n)]
    body = {
        "system": {"A": eye, "B": [["1"]] * n, "C": [["1"] * n], "Q": eye, "R": [["1"]]},
        "channel": {"model": "markov", "order": 3, "arrival_probability": {format(h, "03b"): "1/2" for h in range(8)}},
        "actuator_channel": {"model": "gilbert_elliott", "failure_rate": "1/2", "recovery_rate": "1/2"},
        "controller": {"gains": {"feedback": [["0"] * n], "estimator": [["0"]] * n}},
    }
    with pytest.raises(LimitExceeded) as err:
        analyze_loop(parse_loop_request(body))
    assert err.value.field == "/system/A" and "limit is 3000" in err.value.rule
