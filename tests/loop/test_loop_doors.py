"""The three doors of kfio loop give the same bytes: kfio.loop, ``kfio loop --json``, POST /v1/loop (and its job).

A python-control user's route: discretize a plant, take ``dlqe`` (predictor form) and ``dlqr``
gains, hand them to kfio.loop.  Bad input is named (CLI exit 2, HTTP 422), verdicts map to the
exit codes of ``kfio analyze``.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from pathlib import Path

import control
import numpy as np
import pytest
from fastapi.testclient import TestClient

import kfio
from kfio.loop import loop_request
from kfio.service.app import create_app
from kfio.service.cli import main as cli_main
from kfio.service.settings import Settings

ROOT = Path(__file__).resolve().parents[2]


def _plant():
    """An unstable second-order plant sampled at 0.1 s, with python-control's stationary gains."""
    sys_c = control.ss([[0, 1], [2, -1]], [[0], [1]], [[1, 0]], [[0]])
    sys_d = control.c2d(sys_c, 0.1)
    Q, R = 0.01 * np.eye(2), np.array([[0.04]])
    K, _, _ = control.dlqe(sys_d.A, np.eye(2), sys_d.C, Q, R)  # predictor form: A - K C
    L, _, _ = control.dlqr(sys_d.A, sys_d.B, np.eye(2), np.array([[0.1]]))  # u = -L x
    return sys_d, Q, R, K, L


@pytest.fixture(scope="module")
def plant_request():
    sys_d, Q, R, K, L = _plant()
    args = (
        sys_d,
        {"K": K, "L": L, "form": "predictor"},
        kfio.bernoulli(0.9),
        kfio.gilbert_elliott(failure_rate=0.05, recovery_rate=0.6),
    )
    kw = {"Q": Q, "R": R, "cost": {"W": np.eye(2), "U": [[0.1]]}}
    return kfio.loop(*args, **kw), loop_request(*args, **kw)


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    settings = Settings(workers=1, job_workers=1, time_budget_s=60)
    with TestClient(create_app(settings)) as c:
        deadline = time.monotonic() + 60
        while c.get("/readyz").status_code != 200:
            assert time.monotonic() < deadline, "the worker pools did not start"
            time.sleep(0.05)
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
    exact = report.to_dict()
    assert report.cost is not None and (exact["cost_exact"] is not None or exact["cost_exact_digits"] > 200)
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
    sys_d, Q, R, K, _ = _plant()
    P = control.dare(sys_d.A.T, sys_d.C.T, Q, R)[0]
    predictor = sys_d.A @ P @ sys_d.C.T @ np.linalg.inv(sys_d.C @ P @ sys_d.C.T + R)
    assert np.allclose(K, predictor)


def test_bad_input_is_named_on_every_door(client, capsys, tmp_path):
    body = json.loads((ROOT / "examples" / "loop_scalar.json").read_text())
    body["controller"]["gains"]["L"] = [[1, 2]]
    code, _, err = _cli(capsys, tmp_path, body)
    assert code == 2 and "/controller/gains/L" in err and "1x1" in err
    r = client.post("/v1/loop", json=body)
    assert r.status_code == 422 and "/controller/gains/L" in r.text
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
    assert not schema("loop").is_valid({**body, "controller": {"gains": {"K": [[1]]}}})  # L is required
    code, out, _ = _cli(capsys, tmp_path, body, "--json")
    assert code == 0 and list(schema("loop-report").iter_errors(json.loads(out))) == []
