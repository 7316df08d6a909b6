"""The loop's verdict proved from floats: any size, checked against the exact route.

* the 8-, 9- and 10-state plants of python-control (``c2d``, ``dlqe``, ``dlqr``) answer a report
  through Python, the CLI and HTTP, with the cost's certified enclosure and capped exact texts;
* on small random loops (stable and unstable, TCP/UDP, zero/hold, Bernoulli/Gilbert-Elliott) the
  certified verdict is the exact one, the exact cost lies in the certified enclosure and the exact
  ``rho(T)`` (a root of the characteristic polynomial, Arb ball) in the certified one;
* wrong certificates (perturbed Lyapunov solutions, a Perron candidate of a stable loop) are rejected,
  and the definiteness test agrees with exact ``L D L'`` over Q;
* the certified bracket of a critical value contains the exact value.
"""

from __future__ import annotations

import json
import random
import time
from fractions import Fraction
from pathlib import Path

import flint
import numpy as np
import pytest

from kfio.loop import analyze_loop, decide, loop_mjls, parse_loop_request
from kfio.loop._certify import (
    INDEFINITE_SCALE,
    _Balls,
    _Floats,
    certify,
    definite,
    verify_growth,
    verify_indefinite,
    verify_stable,
)
from kfio.loop._cost import stationary_cost
from kfio.loop._critical import certified_bracket, critical_value, parameter_of
from kfio.loop._operator import operator_matrix
from kfio.model import is_psd
from kfio.service.cli import main as cli_main
from tests.support.loop_plants import GE, ge_two_sensor_request, loop_plant_request

# ----------------------------------------------------------------------------- small random loops


def _num(rng: random.Random, lo: int, hi: int, den: int = 10) -> str:
    return str(Fraction(rng.randint(lo, hi), den))


def _channel(rng: random.Random, ge: bool) -> dict:
    if ge:
        return {"model": "gilbert_elliott", "failure_rate": _num(rng, 1, 4), "recovery_rate": _num(rng, 3, 9)}
    return {"model": "bernoulli", "arrival_probability": _num(rng, 3, 10)}


def _random_loop(seed: int) -> dict:
    """A random loop of 1 or 2 states with short decimal data: verdicts of both kinds occur."""
    rng = random.Random(seed)
    n = rng.choice((1, 2))
    A = [[_num(rng, -14, 14) for _ in range(n)] for _ in range(n)]
    B = [[_num(rng, -10, 10)] for _ in range(n)]
    C = [[_num(rng, -10, 10) for _ in range(n)]]
    K = [[_num(rng, -8, 8)] for _ in range(n)]
    L = [[_num(rng, -8, 8) for _ in range(n)]]
    eye = [["1" if i == j else "0" for j in range(n)] for i in range(n)]
    return {
        "system": {"A": A, "B": B, "C": C, "Q": eye, "R": [["1/2"]]},
        "channel": _channel(rng, rng.random() < 0.4),
        "actuator_channel": _channel(rng, rng.random() < 0.4),
        "controller": {"gains": {"estimator": K, "feedback": L}, "form": rng.choice(("predictor", "filter"))},
        "cost": {"W": eye, "U": [["1/3"]]},
        "options": {"loop": {"protocol": rng.choice(("tcp", "udp")), "on_loss": rng.choice(("zero", "hold"))}},
    }


def _exact_rho(T: flint.fmpq_mat) -> flint.arb:
    """``rho(T)``: the largest modulus of a root of the exact characteristic polynomial, as a 200-bit ball."""
    old = flint.ctx.prec
    flint.ctx.prec = 200
    try:
        best = flint.arb(0)
        for f, _ in T.charpoly().numer().factor()[1]:
            for z, _m in f.complex_roots():
                best = best.max(abs(z))
        return best
    finally:
        flint.ctx.prec = old


def _inside(x: flint.arb, box: tuple[Fraction, Fraction]) -> bool:
    lo, hi = (flint.arb(flint.fmpq(v.numerator, v.denominator)) for v in box)
    return not (x < lo) and not (x > hi)


@pytest.mark.slow
def test_certified_route_agrees_with_the_exact_route_on_random_small_loops() -> None:
    seen = {"stable": 0, "unstable": 0}
    kinds = set()
    for seed in range(60):
        body = _random_loop(seed)
        sys = loop_mjls(parse_loop_request(body))
        exact = decide(sys, route="exact")
        cert = certify(sys)
        if cert.verdict is None:
            continue  # too close to rho = 1 for floats: decide() then runs the exact route
        assert cert.verdict == exact.verdict, seed
        seen[cert.verdict] += 1
        opts = body["options"]["loop"]
        kinds |= {opts["protocol"], opts["on_loss"], body["actuator_channel"]["model"], body["channel"]["model"]}
        assert cert.radius_enclosure is not None and _inside(_exact_rho(operator_matrix(sys)), cert.radius_enclosure)
        if cert.verdict == "stable":
            assert exact.moments is not None and cert.cost_enclosure is not None
            cost = stationary_cost(sys, exact.moments)
            lo, hi = cert.cost_enclosure
            assert lo <= cost <= hi, seed
            assert hi - lo <= Fraction(1, 10**6) * (1 + abs(cost))  # an enclosure, not a shrug
        else:
            assert cert.radius_enclosure[0] > 1
    assert seen["stable"] >= 10 and seen["unstable"] >= 10, seen
    assert kinds >= {"tcp", "udp", "zero", "hold", "bernoulli", "gilbert_elliott"}, kinds


def test_decide_takes_the_certified_route_for_big_operators_and_the_exact_one_for_small() -> None:
    small = loop_mjls(parse_loop_request(_random_loop(1)))
    assert decide(small).exact
    big = loop_mjls(parse_loop_request(loop_plant_request(8)))
    dec = decide(big)
    assert dec.verdict == "stable" and not dec.exact and dec.certified
    assert dec.certificate == "verified float Lyapunov certificate (interval arithmetic, Rump 2006)"
    assert dec.cost_enclosure is not None and dec.cost is not None
    lo, hi = dec.cost_enclosure
    assert lo <= Fraction(dec.cost) <= hi


# ----------------------------------------------------------------------------- wrong certificates


def _float_lyapunov(sys) -> list[np.ndarray]:
    fl = _Floats(sys)
    size = sys.modes * fl.s
    T = np.column_stack([fl.apply(np.eye(size)[:, k]) for k in range(size)])
    ident = fl.vec(np.stack([np.eye(sys.d)] * sys.modes))
    return list(fl.mats(np.linalg.solve(np.eye(size) - T, ident)))


def _ge_loop() -> dict:
    body = _random_loop(0)
    body["system"] = {
        "A": [["1.05", "0.2"], ["0", "0.9"]],
        "B": [["0"], ["1"]],
        "C": [["1", "0"]],
        "Q": [["1", "0"], ["0", "1"]],
        "R": [["1/2"]],
    }
    body["controller"] = {"gains": {"estimator": [["0.8"], ["0.1"]], "feedback": [["0.5", "0.9"]]}, "form": "predictor"}
    body["channel"] = dict(GE)
    body["actuator_channel"] = dict(GE)
    body["options"] = {"loop": {"protocol": "tcp", "on_loss": "zero"}}
    return body


def test_a_planted_wrong_certificate_is_rejected() -> None:
    sys = loop_mjls(parse_loop_request(_ge_loop()))
    assert decide(sys, route="exact").verdict == "stable" and sys.modes == 4
    balls = _Balls(sys)
    Y = _float_lyapunov(sys)
    assert verify_stable(balls, Y) is not None  # the honest certificate verifies
    # one mode's matrix made indefinite: Y_0 is not positive definite
    lam, vecs = np.linalg.eigh(Y[0])
    bad = [Y[0] - 1.01 * lam[0] * np.outer(vecs[:, 0], vecs[:, 0])] + Y[1:]
    assert verify_stable(balls, bad) is None
    # one mode's matrix shrunk: every Y_i stays definite, but Y - T(Y) is not
    shrunk = [0.3 * Y[0]] + Y[1:]
    assert all(np.linalg.eigvalsh(X)[0] > 0 for X in shrunk)
    assert verify_stable(balls, shrunk) is None
    # a Perron "certificate" of instability for a stable loop: T(Y) >= 1.0001 Y is false
    assert not verify_growth(balls, Y, Fraction(10001, 10000))
    # nor does an indefinite candidate prove instability: its residual is far from small
    assert not verify_indefinite(balls, bad, INDEFINITE_SCALE)
    assert not verify_indefinite(balls, Y, INDEFINITE_SCALE)  # the true solution is >= I: nothing to find
    # and a Lyapunov certificate for an unstable loop does not exist: the float solve is rejected
    body = _ge_loop()
    body["system"]["A"] = [["1.6", "0.2"], ["0", "0.9"]]
    unstable = loop_mjls(parse_loop_request(body))
    assert decide(unstable, route="exact").verdict == "unstable"
    assert verify_stable(_Balls(unstable), _float_lyapunov(unstable)) is None
    assert verify_indefinite(_Balls(unstable), _float_lyapunov(unstable), INDEFINITE_SCALE)
    assert certify(unstable).verdict == "unstable"


def test_definiteness_test_agrees_with_exact_ldl_over_q() -> None:
    rng = random.Random(5)
    proved = 0
    for _ in range(300):
        d = rng.randint(1, 5)
        G = [[Fraction(rng.randint(-9, 9), rng.randint(1, 4)) for _ in range(d)] for _ in range(d)]
        shift = Fraction(rng.randint(-30, 30), 4)
        M = [
            [sum((G[i][k] * G[j][k] for k in range(d)), Fraction(0)) + (shift if i == j else 0) for j in range(d)]
            for i in range(d)
        ]
        ball = flint.arb_mat([[flint.arb(flint.fmpq(x.numerator, x.denominator)) for x in row] for row in M])
        exact_pd = is_psd(tuple(map(tuple, M)), strict=True, exact=True)
        if definite(ball):
            assert exact_pd  # never a false proof
            proved += 1
    assert proved >= 50
    # a ball that contains a singular matrix is never proved definite
    sing = flint.arb_mat([[1, 1], [1, 1]]) + flint.arb_mat([[flint.arb(0, 1e-9), 0], [0, 0]])
    assert not definite(sing)


# ----------------------------------------------------------------------------- critical values


@pytest.mark.parametrize("pointer", ["/channel", "/actuator_channel"])
def test_the_certified_bracket_contains_the_exact_critical_value(pointer) -> None:
    body = json.loads((Path(__file__).parents[2] / "examples" / "loop_scalar.json").read_text())
    req = parse_loop_request(body)
    ch = req.channel if pointer == "/channel" else req.actuator
    _, at = parameter_of(pointer, ch)

    def build(c):
        return loop_mjls(req, {pointer: c})

    exact = critical_value("x", pointer, ch, build)
    value = Fraction(exact.exact)
    assert value == (Fraction(9, 16) if pointer == "/channel" else Fraction(75, 152))  # docs/loop.md closed forms
    bracket = certified_bracket("x", f"{pointer}/arrival_probability", lambda x: build(at(x)))
    lo, hi = bracket.bracket
    assert lo <= value <= hi and hi - lo <= Fraction(1, 256)
    assert "certified bracket" in bracket.note and bracket.value is None


# ----------------------------------------------------------------------------- big plants, every door


@pytest.fixture(scope="module")
def big_reports() -> dict[int, tuple[dict, object]]:
    out = {}
    for n in (8, 9, 10):
        body = loop_plant_request(n, seed=n)
        out[n] = (body, analyze_loop(parse_loop_request(body)))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("n", [8, 9, 10])
def test_python_control_plants_of_8_to_10_states_answer_with_certified_enclosures(big_reports, n) -> None:
    body, report = big_reports[n]
    d = json.loads(report.to_json())
    assert d["verdict"] in ("stable", "unstable") and d["certified"]
    assert d["operator_size"] == (2 * n) * (2 * n + 1) // 2 and not d["exact"]
    if d["verdict"] == "stable":
        lo, hi = (Fraction(x) for x in d["cost_enclosure"])
        assert lo <= Fraction(d["cost"]) <= hi and d["cost_exact"] is None
        rlo, rhi = (Fraction(x) for x in d["spectral_radius_enclosure"])
        assert rlo <= Fraction(d["spectral_radius"]) * (1 + Fraction(1, 10**6)) and rhi < 1
    for c in d["critical_values"]:
        assert c["value"] is not None or c["value_bracket"] is not None or "no value" in c["note"]
        if c["value_bracket"] is not None:  # both ends proved: the upper stable, the lower unstable
            lo, hi = (Fraction(x) for x in c["value_bracket_exact"])
            assert lo < hi and "unstable at" in c["note"]
    alone = d["estimator_alone"]["critical_value"]
    if alone is not None and alone["value_minimal_polynomial_digits"] is not None:
        long = alone["value_minimal_polynomial_digits"] > 200
        assert (alone["value_minimal_polynomial"] is None) == long and alone["value_minimal_polynomial_degree"] >= 1
    for text in _texts(d):
        assert len(text) <= 420  # every exact text is capped (200 digits each side of a fraction)


@pytest.mark.slow
@pytest.mark.parametrize("n", [8, 10])
def test_the_summary_of_a_big_plant_prints_each_bracket_as_proved(big_reports, n) -> None:
    from kfio.service.commands.loop import summary

    d = json.loads(big_reports[n][1].to_json())
    lines = summary(d).splitlines()
    assert lines[0].startswith(f"verdict: {d['verdict'].upper()}  (certified mean-square verdict")
    assert all(len(line) <= 160 for line in lines), lines
    for c in d["critical_values"]:
        if c["value_bracket"] is None:
            continue
        lo, hi = c["value_bracket"]
        line = next(x for x in lines if x.startswith(f"critical {c['link']} "))
        assert line.endswith(
            f"in [{lo:.6g}, {hi:.6g}] (certified bracket: proved unstable at {lo:.6g}, stable at {hi:.6g})"
        )


def _texts(tree: object) -> list[str]:
    if isinstance(tree, str):
        return [tree]
    if isinstance(tree, dict):
        return [t for v in tree.values() for t in _texts(v)]
    if isinstance(tree, list):
        return [t for v in tree for t in _texts(v)]
    return []


@pytest.mark.slow
def test_big_plants_answer_through_the_cli_and_http_with_the_same_bytes(big_reports, capsys, tmp_path) -> None:
    from fastapi.testclient import TestClient

    from kfio.service.app import create_app
    from kfio.service.settings import Settings

    body, report = big_reports[9]
    path = tmp_path / "loop.json"
    path.write_text(json.dumps(body))
    code = cli_main(["loop", "--json", str(path)])
    out = capsys.readouterr().out
    assert code == {"stable": 0, "unstable": 1, "boundary": 3}[report.verdict]
    assert out.rstrip("\n") == report.to_json()
    with TestClient(create_app(Settings(workers=1, job_workers=1, time_budget_s=120))) as client:
        deadline = time.monotonic() + 60
        while client.get("/readyz").status_code != 200:
            assert time.monotonic() < deadline
            time.sleep(0.05)
        r = client.post("/v1/loop", json=big_reports[10][0])
        assert r.status_code == 200, r.text
        assert r.json()["verdict"] == big_reports[10][1].verdict


@pytest.mark.slow
def test_exact_costs_past_200_digits_are_null_with_digits_and_an_enclosure() -> None:
    sys = loop_mjls(parse_loop_request(loop_plant_request(4, seed=4)))
    dec = decide(sys)
    assert dec.exact and dec.moments is not None
    report = analyze_loop(parse_loop_request(loop_plant_request(4, seed=4))).to_dict()
    cost = stationary_cost(sys, dec.moments)
    assert report["cost_exact"] is None
    assert report["cost_exact_digits"] == len(str(cost.numerator)) + len(str(cost.denominator)) > 200
    lo, hi = (Fraction(x) for x in report["cost_enclosure"])
    assert lo <= cost <= hi and hi - lo <= cost * Fraction(1, 10**15)


@pytest.mark.slow
def test_the_ten_state_two_sensor_gilbert_elliott_loop_is_certified() -> None:
    sys = loop_mjls(parse_loop_request(ge_two_sensor_request(10)))
    assert sys.modes == 8 and sys.modes * sys.d * (sys.d + 1) // 2 == 1680
    dec = decide(sys)
    assert dec.verdict == "stable" and dec.certified and dec.cost_enclosure is not None
    lo, hi = dec.cost_enclosure
    assert 0 < lo <= Fraction(dec.cost) <= hi and hi - lo <= hi * Fraction(1, 10**6)


def test_capped_texts_count_digits_and_enclose_values_past_pythons_4300_digit_limit() -> None:
    from kfio.model import capped_fraction_text, decimal_enclosure, fraction_digits

    rng = random.Random(11)
    for _ in range(300):
        x = Fraction(rng.randint(-(10**60), 10**60), rng.randint(1, 10 ** rng.randint(1, 80)))
        assert fraction_digits(x) == len(str(abs(x.numerator))) + (0 if x.denominator == 1 else len(str(x.denominator)))
        lo, hi = decimal_enclosure(x, x)
        assert Fraction(lo) <= x <= Fraction(hi) and Fraction(hi) - Fraction(lo) <= abs(x) / 10**15
    huge = Fraction(7**6000, 3**5000 + 1)  # 5071 + 2386 digits: str() of either raises ValueError
    text, digits, box = capped_fraction_text(huge)
    assert text is None and digits == 5071 + 2386 and box is not None
    lo, hi = (Fraction(v) for v in box)
    assert lo <= huge <= hi
    assert capped_fraction_text(Fraction(9, 25)) == ("9/25", 3, None)
