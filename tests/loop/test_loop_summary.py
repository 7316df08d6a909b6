"""``kfio loop`` without ``--json``: every number the summary prints is the report's (headline: the exact verdict)."""

from __future__ import annotations

import json
import re
from fractions import Fraction
from pathlib import Path

import control
import numpy as np
import pytest

import kfio
from kfio.loop import decide, loop_mjls, loop_request, parameter_of, parse_loop_request
from kfio.service.cli import main as cli_main
from kfio.service.commands.loop import summary

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = json.loads((ROOT / "examples" / "loop_scalar.json").read_text())
GAINS = EXAMPLE["controller"]


def _run(capsys, tmp_path: Path, body: dict) -> tuple[list[str], dict]:
    path = tmp_path / "loop.json"
    path.write_text(json.dumps(body))
    assert cli_main(["loop", str(path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert cli_main(["loop", "--json", str(path)]) == 0
    return lines, json.loads(capsys.readouterr().out)


def _line(lines: list[str], prefix: str) -> str:
    found = [line[len(prefix) :] for line in lines if line.startswith(prefix)]
    assert len(found) == 1, (prefix, lines)
    return found[0]


def _decimal_and_exact(text: str) -> tuple[float, str | None]:
    m = re.fullmatch(
        r"(\S+)(?: = (.+)| \((?:algebraic, degree \d+(?:, from float data)?|from float data|\d+-digit fraction)\))?",
        text,
    )
    assert m, text
    return float(m.group(1)), m.group(2)


@pytest.mark.parametrize(
    "controller, protocol",
    [(GAINS, "tcp"), ({"lqg": {"W": [[1]], "U": [[0.5]]}}, "tcp"), (GAINS, "udp")],
    ids=["gains-tcp", "lqg-tcp", "gains-udp"],
)
def test_summary_numbers_are_the_reports(capsys, tmp_path: Path, controller: dict, protocol: str) -> None:
    body = {**EXAMPLE, "controller": controller, "options": {"loop": {"protocol": protocol, "on_loss": "zero"}}}
    lines, report = _run(capsys, tmp_path, body)
    head = re.fullmatch(r"verdict: (\w+)  \(exact mean-square verdict, .*; spectral radius (\S+)\)", lines[0])
    assert head and head.group(1) == report["verdict"].upper()
    assert float(head.group(2)) == pytest.approx(report["spectral_radius"], rel=1e-5)
    assert float(_line(lines, "stationary cost of these gains: ")) == pytest.approx(report["cost"], rel=1e-5)
    for key in ("sensor", "actuator"):
        value, exact = _decimal_and_exact(_line(lines, f"critical {key} arrival probability: "))
        assert value == pytest.approx(report[f"critical_{key}_arrival_probability"], rel=1e-5)
        assert exact in (None, report[f"critical_{key}_arrival_probability_exact"])
        full = report[f"critical_{key}_arrival_probability_exact"]
        if exact is None:  # the decimal is the exact value itself, or the exact text is too long to print
            assert f"{value:.6g}" == full or len(full) > 24
    if "lqg" in controller:
        optimal = report["lqg"]["optimal"]
        bounds = optimal["cost_bounds"]
        m = re.fullmatch(r"between (\S+) and (\S+) \(bounds, .*\)", _line(lines, "optimal TCP-like LQG cost: "))
        assert m and float(m.group(1)) == pytest.approx(bounds["lower"], rel=1e-5)
        assert float(m.group(2)) == pytest.approx(bounds["upper"], rel=1e-5)
        for key, prefix in (("sensor", "  sensor:   optimal > "), ("actuator", "  actuator: optimal > ")):
            m = re.fullmatch(r"(.+) \| stationary (\S+)", _line(lines, prefix))
            assert m, lines
            value, exact = _decimal_and_exact(m.group(1))
            assert exact == optimal[f"critical_{key}_arrival_probability_exact"] == "9/25"  # 1 - 1/a^2, a = 5/4
            assert value == pytest.approx(0.36)
            assert float(m.group(2)) == pytest.approx(report[f"critical_{key}_arrival_probability"], rel=1e-5)
    else:
        assert not any(line.startswith("optimal TCP-like") for line in lines)
    if protocol == "udp":
        outer = report["udp_region_bounds"]["outer"]
        text = _line(lines, "optimal UDP-like controller needs (bound): ")
        assert text == "sensor > 0.36 = 9/25, actuator > 0.36 = 9/25"
        assert (
            outer["sensor_arrival_probability_above_exact"]
            == outer["actuator_arrival_probability_above_exact"]
            == "9/25"
        )
    else:
        assert not any(line.startswith("optimal UDP-like") for line in lines)


def _verdict_at(tree: dict, pointer: str, value: Fraction) -> str:
    """The exact loop verdict with one link parameter (``/actuator_channel/arrival_probability``, ...) set."""
    tree = json.loads(json.dumps(tree))
    *path, key = pointer.strip("/").split("/")
    node = tree
    for part in path:
        node = node[part]
    node[key] = str(value)
    return kfio.loop(tree).verdict


def _pendulum() -> dict:
    """A linearized pendulum sampled at 0.05 s with python-control's dlqr and dlqe gains."""
    plant = control.c2d(control.ss([[0, 1], [9.81, -0.1]], [[0], [1]], [[1, 0]], [[0]]), 0.05)
    Q, R = 1e-2 * np.eye(2), np.array([[1e-2]])
    K, _, _ = control.dlqr(plant.A, plant.B, np.eye(2), np.array([[1.0]]))
    L, _, _ = control.dlqe(plant.A, np.eye(2), plant.C, Q, R)
    return loop_request(
        plant, feedback=K, estimator=L, channel=kfio.bernoulli(0.9), actuator_channel=kfio.bernoulli(0.9), Q=Q, R=R
    )


def test_the_pendulum_summary_prints_both_critical_values_as_decimals() -> None:
    tree = _pendulum()
    report = kfio.loop(tree).to_dict()
    lines = summary(report).splitlines()
    for key, link in (
        ("sensor", "/channel/arrival_probability"),
        ("actuator", "/actuator_channel/arrival_probability"),
    ):
        text = _line(lines, f"critical {key} arrival probability: ")
        m = re.fullmatch(
            r"(0\.\d+) \(algebraic, degree (\d+)(?:, from float data)?\)", text
        )  # the exact text is hundreds of digits
        assert m, text
        critical = next(c for c in report["critical_values"] if c["link"] == key)
        assert int(m.group(2)) == len(critical["value_minimal_polynomial"]) - 1 >= 2
        value = Fraction(m.group(1))
        assert float(value) == pytest.approx(report[f"critical_{key}_arrival_probability"], rel=1e-5)
        # the printed decimal is where the exact verdict changes, to its six digits
        step = Fraction(1, 10**5)
        assert (_verdict_at(tree, link, value - step), _verdict_at(tree, link, value + step)) == ("unstable", "stable")


def test_a_gilbert_elliott_link_prints_its_critical_recovery_rate() -> None:
    body = {**EXAMPLE, "actuator_channel": {"model": "gilbert_elliott", "failure_rate": "0.1", "recovery_rate": "0.6"}}
    report = kfio.loop(body).to_dict()
    text = _line(summary(report).splitlines(), "critical recovery rate of the actuator link: ")
    value, exact = _decimal_and_exact(text)
    assert exact is not None and value == pytest.approx(float(Fraction(exact)), rel=1e-6)
    q = Fraction(exact)
    pointer = "/actuator_channel/recovery_rate"
    tiny = Fraction(1, 10**9)
    assert (_verdict_at(body, pointer, q - tiny), _verdict_at(body, pointer, q + tiny)) == ("unstable", "stable")


def test_a_udp_stable_interval_that_does_not_reach_1_is_printed() -> None:
    body = json.loads((ROOT / "examples" / "loop_udp_interval.json").read_text())
    report = kfio.loop(body).to_dict()
    assert report["verdict"] == "stable" and report["critical_actuator_arrival_probability"] is None
    text = _line(summary(report).splitlines(), "critical actuator arrival probability: ")
    m = re.fullmatch(r"none near 1; stable only for values in \((\S+), (\S+)\)", text)
    assert m, text
    lo, hi = Fraction(m.group(1)), Fraction(m.group(2))
    req = parse_loop_request(body)

    def verdict(nu: Fraction) -> str:  # the link at nu, the estimator's assumed rate nu_bar = 1/2 kept
        _, at = parameter_of("/actuator_channel", req.actuator)
        return decide(loop_mjls(req, {"/actuator_channel": at(nu)})).verdict

    step = Fraction(1, 10**5)
    verdicts = [verdict(x) for x in (lo - step, lo + step, Fraction(1, 2), hi - step, hi + step, Fraction(99, 100))]
    assert verdicts == ["unstable", "stable", "stable", "stable", "unstable", "unstable"]


PER_SENSOR = {
    "system": {
        "A": [["1.1", "0.2"], ["0", "0.9"]],
        "B": [["0"], ["1"]],
        "C": [["1", "0"], ["0", "1"]],
        "Q": [["1", "0"], ["0", "1"]],
        "R": [["1", "0"], ["0", "1"]],
        "sensors": [{"name": "a", "rows": [0]}, {"name": "b", "rows": [1]}],
    },
    "channel": {
        "model": "per_sensor",
        "channels": {
            "a": {"model": "bernoulli", "arrival_probability": "0.8"},
            "b": {"model": "gilbert_elliott", "failure_rate": "0.2", "recovery_rate": "0.7"},
        },
    },
    "actuator_channel": {"model": "bernoulli", "arrival_probability": "0.9"},
    "controller": {"gains": {"feedback": [["0.4", "0.5"]], "estimator": [["0.5", "0"], ["0", "0.3"]]}},
}


def test_a_per_sensor_channel_prints_one_line_per_packet() -> None:
    report = kfio.loop(PER_SENSOR).to_dict()
    lines = summary(report).splitlines()
    a = _line(lines, "critical arrival probability of sensor a: ")
    value, exact = _decimal_and_exact(a)
    assert exact is not None and value == pytest.approx(float(Fraction(exact)), rel=1e-6)
    tiny = Fraction(1, 10**9)
    pointer = "/channel/channels/a/arrival_probability"
    at = [_verdict_at(PER_SENSOR, pointer, Fraction(exact) + d) for d in (-tiny, tiny)]
    assert at == ["unstable", "stable"]
    b = _line(lines, "critical recovery rate of sensor b: ")
    assert b == "0 (stable at every value of this link)"
    assert _verdict_at(PER_SENSOR, "/channel/channels/b/recovery_rate", Fraction(1, 1000)) == "stable"
    _line(lines, "critical actuator arrival probability: ")
    assert len([line for line in lines if line.startswith("critical ")]) == len(report["critical_values"]) == 3
