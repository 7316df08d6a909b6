"""``kfio loop`` without ``--json``: every number the summary prints is the report's (headline: the exact verdict)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from kfio.service.cli import main as cli_main

EXAMPLE = json.loads((Path(__file__).resolve().parents[2] / "examples" / "loop_scalar.json").read_text())
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
    """kfio's number format: ``0.5625 = 9/16``, or the decimal and what a long exact form is."""
    m = re.fullmatch(r"(\S+)(?: = (.+)| \((?:algebraic, degree \d+|from float data|\d+-digit fraction)\))?", text)
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
        whole = report[f"critical_{key}_arrival_probability_exact"]
        assert exact in (None, whole)
        if exact is None:  # the decimal is the exact value itself, or the exact form is long (in --json)
            assert f"{value:.6g}" == whole or len(whole) > 24
    if "lqg" in controller:
        bounds = report["lqg"]["cost_bounds"]
        m = re.fullmatch(r"between (\S+) and (\S+) \(bounds, .*\)", _line(lines, "optimal TCP-like LQG cost: "))
        assert m and float(m.group(1)) == pytest.approx(bounds["lower"], rel=1e-5)
        assert float(m.group(2)) == pytest.approx(bounds["upper"], rel=1e-5)
        nu_c = report["lqg"]["nu_c"]
        value, exact = _decimal_and_exact(
            _line(lines, "control equation converges iff actuator arrival probability > ")
        )
        assert exact == nu_c["exact"] == "9/25" and value == pytest.approx(0.36)  # 1 - 1/a^2, a = 5/4
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
