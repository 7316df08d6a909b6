"""``kfio check`` requirements on closed loops, judged exactly on the loop report.

The loop is ``examples/loop_scalar.json`` (TCP-like, ``a = 5/4``, ``k = 1/2``,
``c = 1``).  The critical sensor probability is checked against the closed
form of the fixed-gain estimator (stable iff ``lam (a - k c)^2 + (1 - lam) a^2 < 1``,
i.e. ``lam > 9/16``), the critical actuator probability by the exact verdict
on both sides of it, and limits set exactly at the measured rationals show
that the comparisons are exact.
"""

from __future__ import annotations

import json
import re
import shutil
from fractions import Fraction
from pathlib import Path

import pytest

from kfio.check import parse_check, run_check
from kfio.errors import InvalidInput
from kfio.loop import analyze_loop, parse_loop_request
from kfio.service import exitcodes

from support.check_layout import run_cli

EXAMPLE = Path(__file__).parents[2] / "examples" / "loop_scalar.json"
LOOP = json.loads(EXAMPLE.read_text())


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    (tmp_path / "loops").mkdir()
    shutil.copy(EXAMPLE, tmp_path / "loops" / "scalar.json")
    slow = {**LOOP, "actuator_channel": {"model": "bernoulli", "arrival_probability": "3/10"}}
    (tmp_path / "loops" / "lossy.json").write_text(json.dumps(slow))
    return tmp_path


def outcomes(folder: Path, loop: str, requirements: dict) -> dict:
    spec = parse_check({"checks": [{"loop": f"loops/{loop}.json", "requirements": requirements}]}, folder)
    return {o.requirement: o for o in run_check(spec, workers=1).outcomes}


@pytest.fixture(scope="module")
def report() -> dict:
    return analyze_loop(parse_loop_request(LOOP)).to_dict()


def test_limits_at_the_exact_values_pass_and_just_below_fail(folder, report) -> None:
    cost = Fraction(report["cost_exact"])
    sensor = Fraction(report["critical_sensor_arrival_probability_exact"])
    actuator = Fraction(report["critical_actuator_arrival_probability_exact"])
    tiny = Fraction(1, 10**15)  # far below float resolution of these values: only an exact comparison sees it
    exact = {
        "loop_verdict": "stable",
        "loop_cost_at_most": str(cost),
        "critical_sensor_arrival_probability_at_most": str(sensor),
        "critical_actuator_arrival_probability_at_most": str(actuator),
    }
    got = outcomes(folder, "scalar", exact)
    assert {k: o.status for k, o in got.items()} == dict.fromkeys(exact, "pass")
    assert got["critical_sensor_arrival_probability_at_most"].measured == "9/16"
    below = {k: str(Fraction(v) - tiny) for k, v in exact.items() if k != "loop_verdict"}
    got = outcomes(folder, "scalar", {**below, "loop_verdict": "unstable"})
    assert {k: o.status for k, o in got.items()} == dict.fromkeys([*below, "loop_verdict"], "fail")


def test_the_measured_critical_values_are_right(report) -> None:
    a, k, c = Fraction(5, 4), Fraction(1, 2), Fraction(1)
    # closed form: the estimator alone is stable iff lam (a - k c)^2 + (1 - lam) a^2 < 1
    lam_c = (a**2 - 1) / (a**2 - (a - k * c) ** 2)
    assert Fraction(report["critical_sensor_arrival_probability_exact"]) == lam_c == Fraction(9, 16)
    nu_c = Fraction(report["critical_actuator_arrival_probability_exact"])
    for nu, verdict in ((nu_c - Fraction(1, 10**6), "unstable"), (nu_c + Fraction(1, 10**6), "stable")):
        tree = {**LOOP, "actuator_channel": {"model": "bernoulli", "arrival_probability": str(nu)}}
        assert analyze_loop(parse_loop_request(tree)).verdict == verdict


def test_an_unstable_loop_fails_its_cost_and_verdict(folder) -> None:
    got = outcomes(folder, "lossy", {"loop_verdict": "stable", "loop_cost_at_most": 1000})
    assert got["loop_verdict"].status == "fail" and got["loop_verdict"].measured == "unstable"
    assert got["loop_cost_at_most"].status == "fail" and got["loop_cost_at_most"].measured == "unbounded"


@pytest.mark.parametrize(
    "entry, field",
    [
        ({"loop": "loops/scalar.json", "requirements": {"verdict": "stable"}}, "/checks/0/requirements/verdict"),
        (
            {"loop": "loops/scalar.json", "plant": "p.json", "requirements": {"loop_verdict": "stable"}},
            "/checks/0/plant",
        ),
        ({"loop": "loops/missing.json", "requirements": {"loop_verdict": "stable"}}, "/checks/0/loop"),
        (
            {"loop": "loops/scalar.json", "requirements": {"loop_cost_at_most": 0}},
            "/checks/0/requirements/loop_cost_at_most",
        ),
        (
            {"loop": "loops/scalar.json", "requirements": {"critical_actuator_arrival_probability_at_most": "3/2"}},
            "/checks/0/requirements/critical_actuator_arrival_probability_at_most",
        ),
    ],
)
def test_bad_loop_entries_name_the_field(folder, entry, field) -> None:
    with pytest.raises(InvalidInput) as err:
        parse_check({"checks": [entry]}, folder)
    assert err.value.field == field


def test_an_invalid_loop_file_names_the_entry_and_the_field_inside(folder) -> None:
    no_b = {**LOOP, "system": {k: v for k, v in LOOP["system"].items() if k != "B"}}
    (folder / "loops" / "no_b.json").write_text(json.dumps(no_b))
    with pytest.raises(InvalidInput) as err:
        parse_check({"checks": [{"loop": "loops/no_b.json", "requirements": {"loop_verdict": "stable"}}]}, folder)
    assert err.value.field == "/checks/0/loop" and "/system" in err.value.rule


def test_cli_exit_codes(folder, capsys) -> None:
    path = folder / "check.json"
    path.write_text(
        json.dumps(
            {
                "checks": [
                    {"name": "ok", "loop": "loops/scalar.json", "requirements": {"loop_verdict": "stable"}},
                    {"name": "lossy", "loop": "loops/lossy.json", "requirements": {"loop_verdict": "stable"}},
                ]
            }
        )
    )
    code, out, _ = run_cli(capsys, str(path), "--workers", "1")
    assert code == exitcodes.UNSTABLE and "lossy" in out


UDP_INTERVAL = Path(__file__).parents[2] / "examples" / "loop_udp_interval.json"


def _udp_verdict(tree: dict, pointer: str, value: Fraction) -> str:
    """The exact verdict with one link at ``value``, the estimator's assumed arrival rate kept (UDP-like)."""
    from kfio.loop import decide, loop_mjls, parameter_of

    req = parse_loop_request(tree)
    channel = req.actuator if pointer == "/actuator_channel" else req.channel
    _, at = parameter_of(pointer, channel)
    return decide(loop_mjls(req, {pointer: at(value)})).verdict


@pytest.mark.parametrize(
    "limit, status",
    [("0.45", "pass"), ("0.6", "pass"), ("0.4", "fail"), ("0.7", "fail"), ("1", "fail")],
)
def test_a_udp_stable_interval_below_1_passes_iff_the_limit_lies_in_it(tmp_path, limit, status) -> None:
    (tmp_path / "loops").mkdir()
    shutil.copy(UDP_INTERVAL, tmp_path / "loops" / "udp.json")
    tree = json.loads(UDP_INTERVAL.read_text())
    key = "critical_actuator_arrival_probability_at_most"
    got = outcomes(tmp_path, "udp", {key: limit, "loop_verdict": "stable"})
    assert got["loop_verdict"].status == "pass"  # stable at its own request point (actuator 1/2)
    o = got[key]
    assert o.status == status, (o.measured, o.detail)
    m = re.fullmatch(r"stable interval \((\S+), (\S+)\)", o.measured)
    assert m and "1/2" in o.detail
    lo, hi = Fraction(m.group(1)), Fraction(m.group(2))
    assert lo < Fraction(1, 2) < hi < 1
    # the semantics, checked against exact verdicts: pass iff the loop is stable with the link at the limit
    v = Fraction(limit)
    assert (_udp_verdict(tree, "/actuator_channel", v) == "stable") == (status == "pass")
    step = Fraction(1, 10**5)
    assert [_udp_verdict(tree, "/actuator_channel", x) for x in (lo - step, lo + step, hi - step, hi + step)] == [
        "unstable",
        "stable",
        "stable",
        "unstable",
    ]


def test_a_loop_unstable_at_its_request_point_fails_though_a_stable_interval_lies_below(tmp_path) -> None:
    tree = json.loads(UDP_INTERVAL.read_text())
    tree["system"]["A"] = [["0.8"]]
    tree["controller"]["gains"] = {"feedback": [["1.5"]], "estimator": [["1.8"]]}
    tree["actuator_channel"]["arrival_probability"] = "0.7"
    tree["channel"]["arrival_probability"] = "0.6"
    (tmp_path / "loops").mkdir()
    (tmp_path / "loops" / "udp.json").write_text(json.dumps(tree))
    report = analyze_loop(parse_loop_request(tree)).to_dict()
    sensor = next(c for c in report["critical_values"] if c["link"] == "sensor")
    assert report["verdict"] == "unstable" and sensor["value"] is None
    assert [i["verdict"] for i in sensor["intervals"]] == ["stable", "unstable"]  # stable only for small arrival
    assert _udp_verdict(tree, "/channel", Fraction(1, 10)) == "stable"
    o = outcomes(tmp_path, "udp", {"critical_sensor_arrival_probability_at_most": "0.1"})[
        "critical_sensor_arrival_probability_at_most"
    ]
    assert o.status == "fail" and o.measured == "none" and "not stable at the request's point 3/5" in o.detail
