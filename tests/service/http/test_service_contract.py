"""The OpenAPI document says what the server does: one test per point that disagreed.

Responses are validated against the checked-in ``openapi/openapi.json`` (the
document clients read), not against the code that generates it.
"""

from __future__ import annotations

import json
import random
import re
from collections.abc import Iterator
from fractions import Fraction
from typing import Any

import jsonschema
import pytest
from fastapi.testclient import TestClient
from referencing import Registry
from referencing.jsonschema import DRAFT202012

from kfio import InvalidInput
from kfio.errors import LimitExceeded
from kfio.model import parse_number
from kfio.service.app import create_app
from kfio.service.settings import Settings

from support.live_server import OPENAPI_PATH
from support.paths import ROOT

DOC: dict[str, Any] = json.loads(OPENAPI_PATH.read_text(encoding="utf-8"))
REGISTRY = Registry().with_resource("urn:kfio:openapi", DRAFT202012.create_resource(DOC))
BOUNDS_BODY = {
    "system": {"A": [[2]], "C": [[1]], "Q": [[1]], "R": [[1]]},
    "channel": {"model": "bernoulli", "arrival_probability": "1/2"},
}


def conforms(name: str, instance: Any) -> None:
    """Raise unless ``instance`` is valid for component ``name`` of the checked-in document."""
    schema = {"$ref": f"urn:kfio:openapi#/components/schemas/{name}"}
    jsonschema.Draft202012Validator(schema, registry=REGISTRY).validate(instance)


def documented_statuses(path: str, method: str) -> set[str]:
    return set(DOC["paths"][path][method]["responses"])


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with TestClient(create_app(Settings(workers=1, job_workers=1))) as c:
        yield c


def test_a_415_names_the_header_and_conforms(client: TestClient) -> None:
    r = client.post("/v1/analyze", content=json.dumps(BOUNDS_BODY), headers={"Content-Type": "text/plain"})
    assert r.status_code == 415
    assert r.json()["in"] == "header" and r.json()["field"] == "Content-Type"
    conforms("Problem", r.json())


def test_a_bad_job_id_names_the_path_and_conforms(client: TestClient) -> None:
    r = client.get("/v1/jobs/" + "x" * 65)  # past the id's documented maxLength
    assert r.status_code == 422
    assert r.json()["in"] == "path"
    conforms("Problem", r.json())
    assert "422" in documented_statuses("/v1/jobs/{job_id}", "get")


@pytest.mark.parametrize("path", ["/v1/jobs/analyze", "/v1/jobs/bounds", "/v1/jobs/simulate", "/v1/sweeps"])
def test_415_is_documented_where_bodies_are_read(client: TestClient, path: str) -> None:
    assert "415" in documented_statuses(path, "post")
    r = client.post(path, content=b"{}", headers={"Content-Type": "application/x-www-form-urlencoded"})
    assert r.status_code == 415
    conforms("Problem", r.json())


def test_405_allows_every_method_of_the_path(client: TestClient) -> None:
    documented = {m.upper() for m in DOC["paths"]["/v1/jobs/{job_id}"]}
    for method in ("OPTIONS", "PUT"):
        r = client.request(method, "/v1/jobs/abc")
        assert r.status_code == 405
        allowed = {m.strip() for m in r.headers["allow"].split(",")}
        assert documented <= allowed == {"GET", "DELETE"}


def test_head_of_the_page_is_200(client: TestClient) -> None:
    r = client.head("/")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/html") and r.content == b""


def number_pattern() -> str:
    """The schema's pattern, read as JSON Schema reads it (ECMA-262: ``$`` is the end of the text;
    Python's ``$`` also matches before a final newline, so it is written ``\\Z`` here)."""
    pattern = DOC["components"]["schemas"]["ExactNumber"]["anyOf"][1]["pattern"]
    return pattern.removesuffix("$") + r"\Z" if pattern.endswith("$") else pattern


def test_exact_number_pattern_refuses_form_feed_and_vertical_tab() -> None:
    assert "\\s" not in number_pattern()
    for text in ("\f2", "2\v", "\u00a02", "\u0661"):
        assert re.search(number_pattern(), text) is None, repr(text)
        with pytest.raises(InvalidInput):
            parse_number(text, "/x")


def test_exact_number_pattern_is_exactly_what_parse_number_accepts() -> None:
    # brute force over short strings of the characters that matter: the schema and the parser agree on each
    rng = random.Random(13)
    alphabet = "0123456789.+-eE/ \t\n\r\f\v\u00a0x"
    accepted = 0
    for _ in range(6000):
        text = "".join(rng.choice(alphabet) for _ in range(rng.randint(1, 7)))
        by_schema = re.search(number_pattern(), text) is not None
        try:
            value = parse_number(text, "/x")
        except LimitExceeded:  # well-formed, past a size rule (digits, exponent) the pattern leaves to the validator
            by_parser = True
        except InvalidInput as exc:
            by_parser = False
            if by_schema:  # a zero denominator is the one grammar-valid text the parser refuses
                assert exc.rule == "division by zero", (text, exc.rule)
                continue
        else:
            by_parser = True
            assert isinstance(value, Fraction)
        assert by_schema == by_parser, repr(text)
        accepted += by_parser
    assert accepted > 150  # the corpus reaches the accepting side too


def test_options_of_another_command_are_checked_like_the_schema_says(client: TestClient) -> None:
    body = {**BOUNDS_BODY, "options": {"analyze": {"x": 1}}}
    r = client.post("/v1/bounds", json=body)
    assert r.status_code == 422, r.text
    assert r.json()["field"] == "/options/analyze/x"
    options = DOC["components"]["schemas"]["Options"]["properties"]
    assert options["analyze"]["additionalProperties"] is False
    for group, command in (("bounds", "/v1/simulate"), ("simulate", "/v1/analyze")):
        assert options[group]["additionalProperties"] is False and "x" not in options[group]["properties"]
        r = client.post(command, json={**BOUNDS_BODY, "options": {group: {"x": 1}}})
        assert r.status_code == 422 and r.json()["field"] == f"/options/{group}/x", r.text


def test_a_huge_integer_is_422_without_python_internals(client: TestClient) -> None:
    text = (
        '{"system": {"A": [['
        + "7" * 5000
        + ']], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": 0.5}}'
    )
    r = client.post("/v1/analyze", content=text, headers={"Content-Type": "application/json"})
    assert r.status_code == 422
    assert "sys." not in r.text and "set_int_max_str_digits" not in r.text
    conforms("Problem", r.json())


def test_problem_in_enum_lists_every_place_the_server_names() -> None:
    assert set(DOC["components"]["schemas"]["Problem"]["properties"]["in"]["enum"]) == {
        "body",
        "query",
        "path",
        "header",
    }


def test_sweep_budgets_are_typed_as_the_validator_reads_them() -> None:
    """``point_budget_s`` and ``time_budget_s`` of a sweep: a number in range or an exact-number string."""
    import json

    doc = json.loads((ROOT / "openapi" / "openapi.json").read_text())
    found = []

    def walk(node: object) -> None:
        if isinstance(node, dict):
            props = node.get("properties")
            if isinstance(props, dict) and "point_budget_s" in props:
                found.append(props)
            for v in node.values():
                walk(v)
        elif isinstance(node, list):
            for v in node:
                walk(v)

    walk(doc)
    assert found
    for props in found:
        for key, upper in (("point_budget_s", 3600), ("time_budget_s", 86400)):
            number, text = props[key]["anyOf"]
            assert number == {"type": "number", "minimum": 0.01, "maximum": upper}
            assert text["type"] == "string" and "pattern" in text
