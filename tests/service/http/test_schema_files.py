"""Published JSON Schemas: generated from the code without drift, valid 2020-12, served, and every example validates.

Every file under examples/ is validated against the schema of its kind (a request,
a sweep, a check file and its plant and channel files; TOML too), and the schemas
are checked not to be vacuous: each refuses a plainly wrong variant of an example.
Reports are validated as kfio prints them.
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import jsonschema
import pytest
from fastapi.testclient import TestClient

from kfio.service.app import create_app
from kfio.service.cli import main
from kfio.service.schema_files import DOCUMENTS, PACKAGE_DIR, texts
from kfio.service.schema_files import main as schema_main
from kfio.service.settings import Settings

from support.paths import ROOT

EXAMPLES = sorted(p for p in (ROOT / "examples").rglob("*") if p.suffix in (".json", ".toml"))


def schema(name: str) -> jsonschema.Draft202012Validator:
    return jsonschema.Draft202012Validator(json.loads((PACKAGE_DIR / f"{name}.json").read_text()))


def load(path: Path):
    return tomllib.loads(path.read_text()) if path.suffix == ".toml" else json.loads(path.read_text())


def kind(path: Path) -> str:
    """The schema of an example: by its folder in a check layout, by its keys otherwise."""
    if path.parent.name in ("plants", "channels"):
        return path.parent.name.removesuffix("s")
    if path.name.startswith("kfio-check"):
        return "check"
    tree = load(path)
    if "actuator_channel" in tree:
        return "loop"
    return "sweep" if {"command", "axes", "requests"} & set(tree) else "request"


def test_written_schemas_match_the_code(capsys):
    assert schema_main(["--check"]) == 0, capsys.readouterr().err
    assert sorted(p.name for p in PACKAGE_DIR.glob("*.json")) == sorted(texts())


def test_check_reports_drift(tmp_path, capsys):
    for name, text in texts().items():
        (tmp_path / name).write_text(text)
    assert schema_main(["--check", "--output", str(tmp_path)]) == 0
    (tmp_path / "check.json").write_text(texts()["check.json"].replace('"minItems": 1', '"minItems": 0', 1))
    assert schema_main(["--check", "--output", str(tmp_path)]) == 1
    assert "check.json is stale" in capsys.readouterr().err


@pytest.mark.parametrize("name", sorted(DOCUMENTS))
def test_schemas_are_2020_12(name):
    doc = json.loads((PACKAGE_DIR / f"{name}.json").read_text())
    assert doc["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    jsonschema.Draft202012Validator.check_schema(doc)
    assert "#/components/" not in json.dumps(doc)  # self-contained: every reference is under $defs


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_example_validates(path):
    errors = list(schema(kind(path)).iter_errors(load(path)))
    assert errors == [], f"{path.name} ({kind(path)}): {errors[0].message}"


@pytest.mark.parametrize(
    ("name", "example", "change"),
    [
        ("request", "seed004_scalar.json", lambda t: t["system"].update(B=[[1]])),
        ("request", "seed004_scalar.json", lambda t: t["channel"].update(arrival_probability=1.5)),
        ("sweep", "sweeps/arrival_probability.json", lambda t: t.update(combine="cross")),
        ("check", "check/kfio-check.json", lambda t: t["checks"][0]["requirements"].update(margn=1)),
        ("check", "check/kfio-check.json", lambda t: t["checks"][0]["requirements"].update(margin=1)),
        ("check", "check/kfio-check.json", lambda t: t["checks"][0].pop("plant")),
        ("plant", "check/plants/scalar.json", lambda t: t["system"].pop("A")),
        ("channel", "check/channels/radio.json", lambda t: t["channel"].update(model="erasure")),
    ],
)
def test_schemas_refuse_what_the_validator_refuses(name, example, change):
    tree = load(ROOT / "examples" / example)
    assert schema(name).is_valid(tree)
    change(tree)
    assert not schema(name).is_valid(tree)


@pytest.mark.parametrize(("command", "name"), [("analyze", "analyze-report"), ("bounds", "bounds-report")])
def test_reports_validate(command, name, capsys):
    main([command, str(ROOT / "examples" / "seed004_scalar.json"), "--json"])
    report = json.loads(capsys.readouterr().out)
    errors = list(schema(name).iter_errors(report))
    assert errors == [], errors[0].message


def test_check_report_validates(capsys):
    code = main(["check", str(ROOT / "examples" / "check" / "kfio-check.toml"), "--json", "--workers", "1"])
    assert code == 0
    assert list(schema("check-report").iter_errors(json.loads(capsys.readouterr().out))) == []


def test_served_at_schemas():
    # no `with`: the lifespan (the worker pool) does not start; serving a file needs none
    client = TestClient(create_app(Settings(workers=1, time_budget_s=20)))
    for name in DOCUMENTS:
        r = client.get(f"/schemas/{name}.json")
        assert r.status_code == 200 and r.headers["content-type"] == "application/schema+json"
        assert r.json() == json.loads((PACKAGE_DIR / f"{name}.json").read_text())
    r = client.get("/schemas/nope.json")
    assert r.status_code == 404 and r.headers["content-type"] == "application/problem+json"
    assert r.json()["status"] == 404 and "nope" in r.json()["detail"]
