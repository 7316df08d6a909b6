"""The HTTP service in-process (FastAPI TestClient, real worker processes)."""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from kfio.service.api.schemas import REQUEST_EXAMPLES
from kfio.service.app import create_app
from kfio.service.cli import main as cli_main
from kfio.service.settings import Settings

from support.live_server import JSON_HEADERS

PROBLEM = "application/problem+json"
SCALAR = REQUEST_EXAMPLES["seed004-scalar"]["value"]  # Sinopoli et al. (2004): lambda_c = 9/25


def wait_ready(client: TestClient, polls: int = 1200) -> None:
    for _ in range(polls):  # bounded by count, not by the clock
        if client.get("/readyz").status_code == 200:
            return
        time.sleep(0.05)
    raise AssertionError("the worker pool did not start")


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with TestClient(create_app(Settings(workers=2, time_budget_s=20))) as c:
        wait_ready(c)
        yield c


def with_channel(body: dict, **channel: object) -> dict:
    return {**body, "channel": {"model": "bernoulli", **channel}}


def run_cli(capsys: pytest.CaptureFixture[str], tmp_path: Path, command: str, body: dict) -> str:
    path = tmp_path / "request.json"
    path.write_text(json.dumps(body))
    cli_main([command, "--json", str(path)])
    return capsys.readouterr().out


# -- health ------------------------------------------------------------------


def test_healthz_and_readyz(client: TestClient) -> None:
    assert client.get("/healthz").json() == {"status": "ok"}
    ready = client.get("/readyz").json()
    assert ready["status"] == "ready"
    assert ready["pool"]["size"] == ready["pool"]["alive"] == 2


def test_docs_page_is_served(client: TestClient) -> None:
    r = client.get("/docs")
    assert r.status_code == 200 and "swagger" in r.text.lower()


# -- one code path: the HTTP answer is the CLI's report ------------------------


@pytest.mark.parametrize(
    ("command", "body"),
    [
        ("analyze", SCALAR),
        ("analyze", REQUEST_EXAMPLES["seed004-3x3"]["value"]),
        ("bounds", REQUEST_EXAMPLES["seed002-2x2"]["value"]),
        ("bounds", REQUEST_EXAMPLES["seed000-two-sensors"]["value"]),
        ("simulate", {**SCALAR, "options": {"simulate": {"steps": 30, "trajectories": 200, "seed": 3}}}),
    ],
)
def test_answer_is_exactly_the_cli_report(
    client: TestClient, capsys: pytest.CaptureFixture[str], tmp_path: Path, command: str, body: dict
) -> None:
    r = client.post(f"/v1/{command}", json=body)
    assert r.status_code == 200, r.text
    assert r.headers["content-type"] == "application/json"
    assert r.text + "\n" == run_cli(capsys, tmp_path, command, body)


def test_numbers_stay_exact(client: TestClient) -> None:
    # lambda = 0.36 is exactly lambda_c = 9/25 for Sinopoli et al. (2004)'s scalar system; read
    # as a double (0.35999999999999998668...) it would be a different verdict.
    for lam in (0.36, "9/25", "0.360"):
        r = client.post("/v1/analyze", json=with_channel(SCALAR, arrival_probability=lam))
        assert r.status_code == 200, r.text
        assert r.json()["verdict"] == "boundary", lam
    assert (
        client.post("/v1/analyze", json=with_channel(SCALAR, arrival_probability=0.3601)).json()["verdict"] == "stable"
    )


def test_identical_requests_are_answered_from_the_cache(client: TestClient) -> None:
    body = with_channel(SCALAR, arrival_probability=0.77)
    first = client.post("/v1/analyze", content=json.dumps(body), headers=JSON_HEADERS)
    # same canonical JSON: other key order, other whitespace
    reordered = json.dumps({"channel": body["channel"], "system": body["system"]}, indent=3)
    second = client.post("/v1/analyze", content=reordered, headers=JSON_HEADERS)
    assert (first.headers["x-cache"], second.headers["x-cache"]) == ("miss", "hit")
    assert first.content == second.content


# -- errors are problem documents -----------------------------------------------


def test_invalid_input_is_422_naming_field_and_rule(client: TestClient) -> None:
    body = {**SCALAR, "system": {**SCALAR["system"], "C": [[1, 2]]}}
    r = client.post("/v1/analyze", json=body)
    assert r.status_code == 422
    assert r.headers["content-type"] == PROBLEM
    doc = r.json()
    assert doc["field"] == "/system/C" and doc["in"] == "body"
    assert "columns" in doc["rule"] and doc["type"] == "urn:kfio:problem:invalid-input"


def test_bad_sdp_cross_check_is_422_naming_the_choices(client: TestClient) -> None:
    body = with_channel(SCALAR, arrival_probability=0.5) | {"options": {"bounds": {"sdp_cross_check": "often"}}}
    r = client.post("/v1/bounds", json=body)
    assert r.status_code == 422 and r.json()["field"] == "/options/bounds/sdp_cross_check"
    assert "'auto', 'always', 'never'" in r.json()["rule"]


def test_probability_out_of_range_names_its_pointer(client: TestClient) -> None:
    r = client.post("/v1/bounds", json=with_channel(SCALAR, arrival_probability=1.5))
    assert r.status_code == 422 and r.json()["field"] == "/channel/arrival_probability"


@pytest.mark.parametrize(
    ("content", "field"),
    [(b'{"system": ', "/"), (b"\xff\xfe", "/"), (b'{"system": {}, "system": {}}', "/"), (b"[]", "/")],
)
def test_malformed_bodies_are_422(client: TestClient, content: bytes, field: str) -> None:
    r = client.post("/v1/analyze", content=content, headers=JSON_HEADERS)
    assert r.status_code == 422 and r.headers["content-type"] == PROBLEM
    assert r.json()["field"] == field


def test_query_parameters_are_validated_as_problems(client: TestClient) -> None:
    r = client.post("/v1/plots/phase-transition?points=1", json=SCALAR)
    assert r.status_code == 422 and r.headers["content-type"] == PROBLEM
    assert (r.json()["field"], r.json()["in"]) == ("/points", "query")
    r = client.post("/v1/plots/phase-transition?lambda_min=0.8&lambda_max=0.5", json=SCALAR)
    assert r.status_code == 422 and r.json()["field"] == "/lambda_max"


def test_body_over_1_mib_is_413(client: TestClient) -> None:
    r = client.post("/v1/analyze", content=b" " * ((1 << 20) + 1), headers=JSON_HEADERS)
    assert r.status_code == 413 and r.headers["content-type"] == PROBLEM


def test_unknown_route_and_method_are_problems(client: TestClient) -> None:
    r = client.get("/v2/nothing")
    assert r.status_code == 404 and r.headers["content-type"] == PROBLEM
    r = client.get("/v1/analyze")
    assert r.status_code == 405 and r.headers["allow"] == "POST"


# -- plots ---------------------------------------------------------------------


def test_simulation_plot_is_png(client: TestClient) -> None:
    body = {**SCALAR, "options": {"simulate": {"steps": 20, "trajectories": 100, "seed": 1}}}
    r = client.post("/v1/plots/simulation", json=body)
    assert r.status_code == 200, r.text
    assert r.headers["content-type"] == "image/png" and r.content.startswith(b"\x89PNG\r\n\x1a\n")


def test_phase_transition_plot_is_png(client: TestClient) -> None:
    r = client.post(
        "/v1/plots/phase-transition?points=20&lambda_min=0.3", json=REQUEST_EXAMPLES["seed004-3x3"]["value"]
    )
    assert r.status_code == 200, r.text
    assert r.headers["content-type"] == "image/png" and r.content.startswith(b"\x89PNG\r\n\x1a\n")


def test_region_plot_is_png(client: TestClient) -> None:
    r = client.post("/v1/plots/region?points=11", json=REQUEST_EXAMPLES["seed000-two-sensors"]["value"])
    assert r.status_code == 200, r.text
    assert r.headers["content-type"] == "image/png" and r.content.startswith(b"\x89PNG\r\n\x1a\n")


@pytest.mark.parametrize("path", ["/v1/plots/region", "/v1/plots/phase-transition"])
def test_plots_refuse_requests_they_cannot_draw(client: TestClient, path: str) -> None:
    # region: one packet; phase transition: two sensors
    body = SCALAR if path.endswith("region") else REQUEST_EXAMPLES["seed000-two-sensors"]["value"]
    r = client.post(path, json=body)
    assert r.status_code == 422 and r.json()["field"] == "/channel/model"


def test_analyze_takes_more_states_than_the_other_routes(client: TestClient) -> None:
    n = 60  # KFIO_MAX_STATES is 40, KFIO_MAX_ANALYZE_STATES 120
    A = [["1/2" if i == j else 0 for j in range(n)] for i in range(n)]
    A[0][0] = "6/5"
    body = {
        "system": {"A": A, "C": [[1] * n], "R": [[1]]},
        "channel": {"model": "bernoulli", "arrival_probability": 0.5},
    }
    r = client.post("/v1/analyze", json=body)
    assert r.status_code == 200 and r.json()["critical_arrival_probability_exact"] == "11/36"
    body["system"]["Q"] = [[int(i == j) for j in range(n)] for i in range(n)]
    r = client.post("/v1/bounds", json=body)
    assert r.status_code == 422 and r.headers["content-type"].startswith(PROBLEM)
    problem = r.json()
    assert problem["field"] == "/system/A"
    assert problem["rule"] == "A has 60 rows; the limit is 40 (kfio analyze accepts up to 120 states)"
