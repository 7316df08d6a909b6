"""The three doors of kfio loop give the same bytes: kfio.loop, ``kfio loop --json``, POST /v1/loop (and its job).

A python-control user's route: discretize a plant, take ``dlqe`` (predictor form) and ``dlqr``
gains, hand them to kfio.loop.  Bad input is named (CLI exit 2, HTTP 422), verdicts map to the
exit codes of ``kfio analyze``.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from fractions import Fraction
from pathlib import Path

import control
import numpy as np
import pytest
from fastapi.testclient import TestClient

import kfio
from kfio.loop import loop_request, parse_loop_request
from kfio.service.cli import main as cli_main
from kfio.service.settings import Settings

from support.app_client import ready_client

ROOT = Path(__file__).resolve().parents[2]


def _plant():
    """An unstable second-order plant sampled at 0.1 s, with python-control's stationary gains."""
    sys_c = control.ss([[0, 1], [2, -1]], [[0], [1]], [[1, 0]], [[0]])
    sys_d = control.c2d(sys_c, 0.1)
    Q, R = 0.01 * np.eye(2), np.array([[0.04]])
    # python-control's names: dlqr's K is the feedback (u = -K x), dlqe's L the estimator (eig(A - L C))
    K, _, _ = control.dlqr(sys_d.A, sys_d.B, np.eye(2), np.array([[0.1]]))
    L, _, _ = control.dlqe(sys_d.A, np.eye(2), sys_d.C, Q, R)
    return sys_d, Q, R, K, L


@pytest.fixture(scope="module")
def plant_request():
    sys_d, Q, R, K, L = _plant()
    kw = {
        "feedback": K,
        "estimator": L,
        "form": "predictor",
        "channel": kfio.bernoulli(0.9),
        "actuator_channel": kfio.gilbert_elliott(failure_rate=0.05, recovery_rate=0.6),
        "Q": Q,
        "R": R,
        "cost": {"W": np.eye(2), "U": [[0.1]]},
    }
    return kfio.loop(sys_d, **kw), loop_request(sys_d, **kw)


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    settings = Settings(workers=1, job_workers=1, time_budget_s=60)
    with ready_client(settings) as c:
        yield c


def _cli(capsys, tmp_path: Path, body: dict, *flags: str) -> tuple[int, str, str]:
    path = tmp_path / "loop.json"
    path.write_text(json.dumps(body))
    code = cli_main(["loop", *flags, str(path)])
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.slow
def test_python_control_gains_give_one_report_through_every_door(plant_request, client, capsys, tmp_path):
    report, body = plant_request
    assert report.verdict == "stable" and report.exact and report.certified
    # float gains: the exact cost has hundreds of digits, so the report gives its digit count and a
    # certified decimal enclosure instead of the text (200-digit cap); the float lies inside it
    doc = report.to_dict()
    assert report.cost is not None and doc["cost_exact"] is None and doc["cost_exact_digits"] > 200
    lo, hi = (float(x) for x in doc["cost_enclosure"])
    assert lo <= report.cost <= hi
    code, out, _ = _cli(capsys, tmp_path, body, "--json")
    assert code == 0
    assert out.rstrip("\n") == report.to_json()
    r = client.post("/v1/loop", json=body)
    assert r.status_code == 200, r.text
    assert r.content.decode() == report.to_json()
    job = client.post("/v1/jobs/loop", json=body)
    assert job.status_code == 202, job.text
    location = job.headers["location"]
    deadline = time.monotonic() + 120
    while (doc := client.get(location).json())["status"] not in {"done", "failed"}:
        assert time.monotonic() < deadline
        time.sleep(0.05)
    assert doc["status"] == "done", doc
    assert client.get(location + "/result").content == r.content


def test_python_control_predictor_gain_is_the_one_dlqe_documents():
    sys_d, Q, R, _, L = _plant()
    P = control.dare(sys_d.A.T, sys_d.C.T, Q, R)[0]
    predictor = sys_d.A @ P @ sys_d.C.T @ np.linalg.inv(sys_d.C @ P @ sys_d.C.T + R)
    assert np.allclose(L, predictor)


def test_bad_input_is_named_on_every_door(client, capsys, tmp_path):
    body = json.loads((ROOT / "examples" / "loop_scalar.json").read_text())
    body["controller"]["gains"]["feedback"] = [[1, 2]]
    code, _, err = _cli(capsys, tmp_path, body)
    assert code == 2 and "/controller/gains/feedback" in err and "1x1" in err
    r = client.post("/v1/loop", json=body)
    assert r.status_code == 422 and "/controller/gains/feedback" in r.text
    good = json.loads((ROOT / "examples" / "loop_scalar.json").read_text())
    r = client.post("/v1/jobs/loop", json={**good, "options": {"loop": {"protocol": "quic"}}})
    assert r.status_code == 422 and "/options/loop/protocol" in r.text


@pytest.mark.parametrize("nu,code", [("9/10", 0), ("1/10", 1)])
def test_exit_codes_follow_the_verdict(capsys, tmp_path, nu, code):
    body = json.loads((ROOT / "examples" / "loop_scalar.json").read_text())
    body["actuator_channel"]["arrival_probability"] = nu
    got, out, _ = _cli(capsys, tmp_path, body)
    assert got == code and out.startswith("verdict: " + ("STABLE  " if code == 0 else "UNSTABLE  "))


def test_the_loop_report_and_request_validate_against_their_published_schemas(capsys, tmp_path):
    import jsonschema

    from kfio.service.schema_files import PACKAGE_DIR

    def schema(name: str) -> jsonschema.Draft202012Validator:
        return jsonschema.Draft202012Validator(json.loads((PACKAGE_DIR / f"{name}.json").read_text()))

    body = json.loads((ROOT / "examples" / "loop_scalar.json").read_text())
    assert schema("loop").is_valid(body)
    assert not schema("loop").is_valid({**body, "controller": {"gains": {"estimator": [[1]]}}})  # feedback is required
    code, out, _ = _cli(capsys, tmp_path, body, "--json")
    assert code == 0 and list(schema("loop-report").iter_errors(json.loads(out))) == []


@pytest.mark.parametrize("letter", ["K", "L"])
def test_the_letters_K_and_L_are_refused_saying_which_gain_is_which(client, capsys, tmp_path, letter):
    body = json.loads((ROOT / "examples" / "loop_scalar.json").read_text())
    gains = body["controller"]["gains"]
    body["controller"]["gains"] = {letter: gains["feedback"], **gains}  # a letter beside the roles is refused too
    explanation = "'feedback' (u = -F x_hat; python-control's dlqr K) and 'estimator' (python-control's dlqe L)"
    for tree in (body, {**body, "controller": {"gains": {"K": gains["feedback"], "L": gains["estimator"]}}}):
        with pytest.raises(kfio.InvalidInput) as err:
            kfio.loop(tree)
        field = f"/controller/gains/{letter}" if tree is body else "/controller/gains/K"
        assert err.value.field == field and explanation in err.value.rule
    code, _, err_text = _cli(capsys, tmp_path, body)
    assert code == 2 and f"/controller/gains/{letter}" in err_text and explanation in err_text
    r = client.post("/v1/loop", json=body)
    assert r.status_code == 422 and f"/controller/gains/{letter}" in r.text and "dlqr K" in r.text


def test_python_control_gains_by_role_match_the_json_door_and_swapped_gains_do_not():
    sys_d, Q, R, K, L = _plant()
    common = {"channel": kfio.bernoulli(0.9), "actuator_channel": kfio.bernoulli(0.8), "Q": Q, "R": R}
    report = kfio.loop(sys_d, feedback=K, estimator=L, **common)
    body = loop_request(sys_d, feedback=K, estimator=L, **common)
    req = parse_loop_request(body)
    assert req.feedback == tuple(tuple(Fraction(repr(float(x))) for x in row) for row in K)  # the floats' decimal text
    assert req.estimator == tuple(tuple(Fraction(repr(float(x))) for x in row) for row in L)
    assert report.to_json() == kfio.loop(json.loads(json.dumps(body))).to_json()
    # the closed loop's mean dynamics (both links perfect) is eig(A - B K) and eig(A - L C), as python-control says
    assert report.verdict == "stable"
    assert (
        max(abs(np.linalg.eigvals(sys_d.A - sys_d.B @ K))) < 1
        and max(abs(np.linalg.eigvals(sys_d.A - L @ sys_d.C))) < 1
    )
    with pytest.raises(kfio.InvalidInput) as err:  # the shapes differ here: swapped gains are named
        kfio.loop(sys_d, feedback=L, estimator=K, **common)
    assert err.value.field == "feedback" and "1x2" in err.value.rule


def test_python_arguments_are_named_in_errors():
    sys_d, Q, R, K, L = _plant()
    with pytest.raises(kfio.InvalidInput) as err:
        kfio.loop(
            sys_d, feedback=K, estimator=L, channel=kfio.bernoulli(0.9), actuator_channel={"model": "x"}, Q=Q, R=R
        )
    assert err.value.field.startswith("actuator_channel")
    with pytest.raises(kfio.InvalidInput) as err:
        kfio.loop(sys_d, feedback=K, channel=kfio.bernoulli(0.9), actuator_channel=kfio.bernoulli(0.9), Q=Q, R=R)
    assert err.value.field == "estimator"
    links = {"channel": kfio.bernoulli(0.9), "actuator_channel": kfio.bernoulli(0.9)}
    for kw, field in (({"R": R}, "Q"), ({"Q": -Q, "R": R}, "Q"), ({"Q": Q, "R": R, "B": [[1, 2]]}, "B")):
        with pytest.raises(kfio.InvalidInput) as err:  # the plant's keywords are named as keywords
            kfio.loop(sys_d, feedback=K, estimator=L, **links, **kw)
        assert err.value.field == field, (kw, err.value)


def test_typed_parts_of_the_report_are_its_json_with_values_derived_by_hand():
    # a = 5/4, b = c = 1, estimator k = 1/2, feedback 3/5 (examples/loop_scalar.json): the estimator alone is
    # stable iff lam (a - k)^2 + (1 - lam) a^2 < 1, i.e. lam > 9/16; the optimal filter needs 1 - 1/a^2 = 9/25;
    # the plant under u = -F x_hat needs nu (a - F)^2 + (1 - nu) a^2 < 1, i.e. nu > 75/152, wherever lam > 9/16
    body = json.loads((ROOT / "examples" / "loop_scalar.json").read_text())
    body["options"]["loop"]["region"] = 4
    report = kfio.loop(body)
    d = report.to_dict()
    assert json.loads(report.to_json()) == d
    alone = report.estimator_alone
    assert type(alone.verdict) is kfio.Verdict and alone.to_dict() == d["estimator_alone"]
    assert alone.critical_sensor_arrival_probability_exact == "9/16"
    assert alone.exact_of("critical_sensor_arrival_probability") == Fraction(9, 16)
    assert report.exact_of("critical_actuator_arrival_probability") == Fraction(75, 152)
    assert alone.optimal_filter.critical_arrival_probability_exact == "9/25"
    assert alone.statement == "the optimal time-varying filter needs 9/25; your steady-state gain needs 9/16"
    region = report.region
    assert region is not None and region.to_dict() == d["region"]
    assert [p.sensor for p in region.boundary] == [Fraction(1, 8), Fraction(3, 8), Fraction(5, 8), Fraction(7, 8)]
    assert [p.critical_actuator_arrival_probability_exact for p in region.boundary] == [None, None, "75/152", "75/152"]
    assert report.udp_region_bounds is None and d["udp_region_bounds"] is None
    for on_loss in ("zero", "hold"):
        body["options"]["loop"] = {"protocol": "udp", "on_loss": on_loss}
        udp = kfio.loop(body)
        bounds = udp.udp_region_bounds
        assert bounds is not None and bounds.to_dict() == udp.to_dict()["udp_region_bounds"]
        outer = bounds.outer
        assert outer is not None and outer.sensor_arrival_probability_above_exact == "9/25"
        assert outer.actuator_arrival_probability_above_exact == (None if on_loss == "hold" else "9/25")
        assert bounds.request_point_inside_optimal_region is (udp.verdict == "stable")


def test_one_report_from_a_request_dict_a_validated_request_and_keywords():
    body = json.loads((ROOT / "examples" / "loop_scalar.json").read_text())
    req = parse_loop_request(body)
    assert req.K is req.estimator and req.L is req.feedback  # the letters of Schenato et al. (2007), read-only
    assert (req.feedback, req.estimator) == (((Fraction(3, 5),),), ((Fraction(1, 2),),))
    plant = kfio.System(A=[[1.25]], C=[[1]], Q=[[1]], R=[[0.5]])
    by_keywords = kfio.loop(
        plant,
        B=[[1]],
        feedback=[[0.6]],
        estimator=[[0.5]],
        form="predictor",
        channel=kfio.bernoulli(0.8),
        actuator_channel=kfio.bernoulli(0.9),
        cost={"W": [[1]], "U": [[0.5]]},
        options={"protocol": "tcp", "on_loss": "zero"},
        budget=60,
    )
    assert by_keywords.to_json() == kfio.loop(body).to_json() == kfio.loop(req, budget=60).to_json()
    with pytest.raises(kfio.InvalidInput) as err:
        kfio.loop(body, feedback=[[0.6]])
    assert err.value.field == "system" and "only budget" in err.value.rule
