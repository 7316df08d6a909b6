"""Lone surrogates are refused with a clear error, never a UnicodeEncodeError.

Reproducers: ``"\\ud800"`` in a field name, a per-sensor channel key, a Markov
history key or an option key gave HTTP 500 (the problem document could not be
encoded); a sensor name holding one made ``kfio analyze`` without ``--json``
exit 70.  The escape is ASCII in the request body; the decoded string is no
Unicode text, and I-JSON (RFC 7493) forbids it.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient

from kfio import InvalidInput, load_request
from kfio.service.app import create_app
from kfio.service.cli import main
from kfio.service.io import emit
from kfio.service.problems import problem_from_exception
from kfio.service.settings import Settings

LONE = "\\ud800"  # the six ASCII characters of the JSON escape

SENSORS = (
    '{"system": {"A": [[2, 0], [0, 3]], "C": [[1, 0], [0, 1]], '
    '"sensors": [{"name": "NAME1", "rows": [0]}, {"name": "b", "rows": [1]}]}, '
    '"channel": {"model": "per_sensor", "channels": {"KEY1": {"model": "bernoulli", "arrival_probability": 0.9}, '
    '"b": {"model": "bernoulli", "arrival_probability": 0.9}}}}'
)
MARKOV = (
    '{"system": {"A": [[2]], "C": [[1]]}, "channel": {"model": "markov", "order": 1, '
    '"arrival_probability": {"0": 0.5, "HIST": 0.5}}}'
)
SCALAR = '{"system": {"A": [[2]], "C": [[1]]SYS}, "channel": {"model": "bernoulli", "arrival_probability": 0.9}OPT}'

CASES = {
    "field name": (SCALAR.replace("SYS", f', "x{LONE}": 1').replace("OPT", ""), "/system/x\\ud800"),
    "sensor name": (SENSORS.replace("NAME1", f"a{LONE}").replace("KEY1", f"a{LONE}"), "/system/sensors/0/name"),
    "channel key": (SENSORS.replace("NAME1", "a").replace("KEY1", f"a{LONE}"), "/channel/channels/a\\ud800"),
    "history key": (MARKOV.replace("HIST", f"1{LONE}"), "/channel/arrival_probability/1\\ud800"),
    "option key": (
        SCALAR.replace("SYS", "").replace("OPT", f', "options": {{"simulate": {{"st{LONE}": 1}}}}'),
        "/options/simulate/st\\ud800",
    ),
    "low surrogate value": (SCALAR.replace("SYS", "").replace("0.9", '"0.9\\udc00"').replace("OPT", ""), None),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_library_refuses_lone_surrogates_naming_the_field(case: str) -> None:
    body, field = CASES[case]
    with pytest.raises(InvalidInput, match="lone surrogate") as err:
        load_request(body)
    if field is not None:
        assert err.value.field == field
    str(err.value).encode("utf-8")  # the message itself is encodable


def test_valid_surrogate_pairs_are_text() -> None:
    body = SENSORS.replace("NAME1", "\\ud83d\\ude00").replace("KEY1", "\\ud83d\\ude00")
    assert load_request(body).system.sensors[0].name == "\U0001f600"


@pytest.mark.parametrize("case", sorted(CASES))
def test_cli_exits_2_with_an_encodable_message(case: str, tmp_path, capsys) -> None:
    path = tmp_path / "r.json"
    path.write_text(CASES[case][0])
    assert main(["analyze", str(path)]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.startswith("kfio: invalid input at ") and "lone surrogate" in err


def test_problem_documents_and_printing_escape_what_cannot_be_encoded(capsys) -> None:
    exc = InvalidInput("/system/" + chr(0xD800), "unknown field '" + chr(0xDC00) + "'")
    response = problem_from_exception(exc).response()  # rendering encodes the body as UTF-8
    doc = json.loads(response.body)
    assert doc["field"] == "/system/\\ud800" and doc["rule"] == "unknown field '\\udc00'"
    emit("sensor " + chr(0xD800))
    assert capsys.readouterr().out == "sensor \\ud800\n"


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with TestClient(create_app(Settings(workers=1, time_budget_s=20))) as c:
        deadline = time.monotonic() + 30
        while c.get("/readyz").status_code != 200 and time.monotonic() < deadline:
            time.sleep(0.05)
        yield c


@pytest.mark.parametrize("case", sorted(CASES))
def test_http_answers_422_problem_json(client: TestClient, case: str) -> None:
    body, field = CASES[case]
    r = client.post("/v1/analyze", content=body.encode("ascii"), headers={"content-type": "application/json"})
    assert r.status_code == 422 and r.headers["content-type"].startswith("application/problem+json")
    doc = r.json()
    assert "lone surrogate" in doc["rule"]
    if field is not None:
        assert doc["field"] == field


def test_plain_requests_cost_no_tree_walk(monkeypatch: pytest.MonkeyPatch) -> None:
    # the walk runs only when the text holds a surrogate escape: a 1 MiB body of numbers is not walked
    from kfio.model import _exact

    walks = []
    real = _exact._reject_lone_surrogates
    monkeypatch.setattr(_exact, "_reject_lone_surrogates", lambda tree: walks.append(1) or real(tree))
    _exact.load_json(json.dumps({"system": {"A": [[1] * 100_000]}, "name": "\u00e9\U0001f600"}, ensure_ascii=False))
    assert walks == []
    with pytest.raises(InvalidInput, match="lone surrogate"):
        _exact.load_json('{"a": ["x", "\\uDBFF"]}')
    assert walks == [1]
