"""Error bodies are small whatever the request held.

A 1 MB unknown key or a 1 MB ``options.loop.protocol`` value was answered with
a 2 MB 422 body (the value twice, in ``field``/``rule`` and in ``detail``).
Every echoed client value is now cut to ``ECHO_LIMIT`` characters and every
problem member is bounded; the CLI prints one short line.
"""

from __future__ import annotations

import json
from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient

from kfio.errors import ECHO_LIMIT
from kfio.service import exitcodes
from kfio.service.cli import main as cli_main
from kfio.service.problems import TEXT_LIMIT, Problem
from kfio.service.settings import Settings

from support.app_client import ready_client
from support.paths import ROOT

EXAMPLES = ROOT / "examples"
MB = 1_000_000
BODY_LIMIT = 64 * 1024
HUGE = "k" * MB


def _request() -> dict:
    return {
        "system": {"A": [[2]], "C": [[1]]},
        "channel": {"model": "bernoulli", "arrival_probability": "1/2"},
    }


def _loop() -> dict:
    return json.loads((EXAMPLES / "loop_scalar.json").read_text())


def _hostile() -> dict[str, tuple[str, dict, str]]:
    """Name -> (route, body, the field the 422 names (its start, for a clipped key))."""
    top = {**_request(), HUGE: 1}
    option = {**_request(), "options": {"analyze": {HUGE: 1}}}
    model = {**_request(), "channel": {"model": HUGE}}
    number = {**_request(), "system": {"A": [[HUGE]], "C": [[1]]}}
    sensor = {**_request(), "channel": {"model": "per_sensor", "channels": {HUGE: {"model": "bernoulli"}}}}
    protocol = _loop()
    protocol["options"]["loop"]["protocol"] = "p" * MB
    form = _loop()
    form["controller"]["form"] = "f" * MB
    return {
        "unknown top-level key": ("/v1/analyze", top, "/" + "k" * ECHO_LIMIT + "..."),
        "unknown option key": ("/v1/analyze", option, "/options/analyze/" + "k" * ECHO_LIMIT + "..."),
        "channel model": ("/v1/analyze", model, "/channel/model"),
        "number text": ("/v1/analyze", number, "/system/A/0/0"),
        "per-sensor key": ("/v1/bounds", sensor, "/channel"),
        "loop protocol": ("/v1/loop", protocol, "/options/loop/protocol"),
        "loop form": ("/v1/loop", form, "/controller/form"),
    }


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with ready_client(Settings(workers=1, job_workers=1, time_budget_s=30)) as c:
        yield c


@pytest.mark.parametrize("name", list(_hostile()))
def test_a_megabyte_value_gets_a_small_422(client: TestClient, name: str) -> None:
    route, body, field = _hostile()[name]
    data = json.dumps(body).encode()
    assert len(data) > MB
    r = client.post(route, content=data, headers={"Content-Type": "application/json"})
    assert r.status_code == 422, r.text[:500]
    assert r.headers["content-type"].startswith("application/problem+json")
    assert len(r.content) < BODY_LIMIT, len(r.content)
    doc = r.json()
    assert doc["field"].startswith(field), doc["field"][:200]
    for member in ("field", "rule", "detail"):  # no run of the client's text longer than the echo limit
        for ch in "kpf":
            assert ch * (ECHO_LIMIT + 1) not in doc[member], (member, doc[member][:300])


def test_every_problem_member_is_bounded() -> None:
    doc = Problem(422, "analysis-error", "t", "d" * MB, field="/" + "x" * MB, rule="r" * MB).to_dict()
    assert all(len(doc[k]) <= TEXT_LIMIT + 3 for k in ("detail", "field", "rule"))
    assert len(json.dumps(doc)) < BODY_LIMIT


@pytest.mark.parametrize("name", ["unknown top-level key", "loop protocol", "channel model"])
def test_the_cli_prints_one_short_line(tmp_path, capsys, name: str) -> None:
    route, body, field = _hostile()[name]
    path = tmp_path / "req.json"
    path.write_text(json.dumps(body))
    command = "loop" if route == "/v1/loop" else "analyze"
    code = cli_main([command, str(path), "--json"])
    out, err = capsys.readouterr()
    assert code == exitcodes.INVALID_INPUT == 2
    assert out == "" and len(err.splitlines()) == 1 and len(err) < 1000, len(err)
    assert err.startswith(f"kfio: invalid input at {field}")
