"""The checked-in OpenAPI contract: fresh, complete, and its examples are true."""

from __future__ import annotations

import json
from typing import Any

import jsonschema
import pytest
from referencing import Registry
from referencing.jsonschema import DRAFT202012

from kfio import load_request
from kfio.service.openapi_gen import generate, main

from support.live_server import OPENAPI_PATH as DEFAULT_PATH

DOC: dict[str, Any] = json.loads(DEFAULT_PATH.read_text(encoding="utf-8"))
COMPONENTS: dict[str, Any] = DOC["components"]["schemas"]
POSTS = {path: ops["post"] for path, ops in DOC["paths"].items() if "post" in ops}


def validator(name: str) -> jsonschema.protocols.Validator:
    """A validator of component ``name`` that resolves ``#/components/schemas/...``."""
    registry = Registry().with_resource("urn:kfio:openapi", DRAFT202012.create_resource(DOC))
    schema = {"$ref": f"urn:kfio:openapi#/components/schemas/{name}"}
    return jsonschema.Draft202012Validator(schema, registry=registry)


def test_checked_in_openapi_is_fresh() -> None:
    assert DEFAULT_PATH.read_text(encoding="utf-8") == generate(), (
        "openapi/openapi.json is stale: run `python -m kfio.service.openapi_gen` and commit the result"
    )
    assert main(["--check"]) == 0


def test_check_mode_detects_a_stale_file(tmp_path: Any) -> None:
    stale = tmp_path / "openapi.json"
    stale.write_text("{}\n")
    assert main(["--check", "--output", str(stale)]) == 1
    assert main(["--output", str(stale)]) == 0 and main(["--check", "--output", str(stale)]) == 0


@pytest.mark.parametrize("name", sorted(COMPONENTS))
def test_every_schema_has_examples_that_it_accepts(name: str) -> None:
    examples = COMPONENTS[name].get("examples")
    assert examples, f"component {name} has no examples"
    for example in examples:
        validator(name).validate(example)


@pytest.mark.parametrize("path", sorted(POSTS))
def test_every_post_documents_body_examples_and_errors(path: str) -> None:
    op = POSTS[path]
    content = op["requestBody"]["content"]["application/json"]
    if path == "/v1/sweeps":
        from kfio.sweep import load_sweep, validate_points

        assert {"base", "axes", "requests", "combine"} <= set(content["schema"]["properties"])
        # the route takes any object as base: every point is validated by the job's worker; the published
        # file schema (sweep.json) names the request schemas, a loop request for "command": "loop"
        assert content["schema"]["properties"]["base"]["type"] == "object"
        from kfio.service.api.sweeps import SWEEP_SCHEMA

        refs = [{"$ref": "#/components/schemas/AnalysisRequest"}, {"$ref": "#/components/schemas/LoopRequest"}]
        assert SWEEP_SCHEMA["properties"]["base"]["anyOf"] == refs
        for example in content["examples"].values():
            validator("AnalysisRequest").validate(example["value"]["base"])
            assert validate_points(load_sweep(json.dumps(example["value"])))  # the sweep validator accepts it
        assert {"202", "413", "422", "429", "503"} <= set(op["responses"])
        return
    kind, load = "AnalysisRequest", load_request
    if path in ("/v1/loop", "/v1/jobs/loop", "/v1/plots/loop-region"):
        from kfio.loop import load_loop_request

        kind, load = "LoopRequest", load_loop_request
    if path == "/v1/plots/trace-region":  # an analyze request whose channel is a measured trace
        from kfio.fit import load_trace_request as load
    if path in ("/v1/fit", "/v1/jobs/fit"):
        from kfio.fit import fit_request

        kind, load = "FitRequest", lambda text: fit_request(json.loads(text))
    assert content["schema"] == {"$ref": f"#/components/schemas/{kind}"}
    assert content["examples"], path
    for example in content["examples"].values():
        validator(kind).validate(example["value"])
        load(json.dumps(example["value"]))  # the one validator accepts it too
    # a job answers 202 at once (429 when the queue is full); its budget is reported when it is polled
    expected = (
        ("202", "413", "422", "429", "503") if path.startswith("/v1/jobs/") else ("200", "413", "422", "503", "504")
    )
    assert set(expected) <= set(op["responses"]), path
    for status in expected[1:]:
        assert "application/problem+json" in op["responses"][status]["content"]


def test_schema_refuses_what_the_validator_refuses() -> None:
    bad = [
        {"system": {"A": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": 0.5}},  # no C
        {"system": {"A": [[1]], "C": [[1]]}, "channel": {"model": "bernoulli"}},
        {"system": {"A": [[1]], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": 2}},
        {"system": {"A": [[1]], "C": [[1]]}, "channel": {"model": "x"}, "extra": 1},
        {"system": {"A": [["one"]], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": 0.5}},
    ]
    v = validator("AnalysisRequest")
    for body in bad:
        assert not v.is_valid(body), body
        with pytest.raises(ValueError):
            load_request(json.dumps(body))
