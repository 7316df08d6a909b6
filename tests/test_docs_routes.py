"""Docs that cannot fall behind the code: routes, OpenAPI jobs, the Python API, help(), counts.

* ``docs/service.md``'s endpoint table names every route the app serves, and nothing it does not;
* the OpenAPI description names the job route of every command that has one;
* ``docs/python_api.md`` names every name of ``kfio.__all__`` (read when the test runs, so a new
  public function fails here until it is documented);
* ``help()`` of every public function shows its signature and a short example;
* no page states a test count, which changes with every test added.
"""

from __future__ import annotations

import inspect
import pydoc
import re
from pathlib import Path

import pytest

import kfio

ROOT = Path(__file__).resolve().parents[1]
SERVICE_MD = ROOT / "docs" / "service.md"
PYTHON_API_MD = ROOT / "docs" / "python_api.md"
METHODS = ("GET", "POST", "DELETE", "PUT", "PATCH")
ROUTE = re.compile(r"`(GET|POST|DELETE|PUT|PATCH) (/[^`?\s]*)")


def _normal(path: str) -> str:
    """Path parameters by position only: ``/v1/jobs/{id}`` and ``/v1/jobs/{job_id}`` are one route."""
    return re.sub(r"\{[^}]*\}", "{}", path)


def _app_routes() -> set[tuple[str, str]]:
    """(method, path) of every route of the app, included routers too; HEAD goes with GET."""
    from kfio.service.app import create_app

    found: set[tuple[str, str]] = set()

    def walk(routes: list) -> None:
        for route in routes:
            inner = getattr(route, "original_router", None)
            if inner is not None:
                walk(inner.routes)
                continue
            path = getattr(route, "path", None)
            methods = getattr(route, "methods", None) or set()
            if path is None or not methods:
                continue  # a mount of static files: its folder is named in the table's last row
            for method in methods:
                if method in METHODS:
                    found.add((method, _normal(path)))

    walk(create_app().routes)
    return found


def _documented_routes() -> set[tuple[str, str]]:
    text = SERVICE_MD.read_text(encoding="utf-8")
    section = text.split("## Endpoints", 1)[1].split("\n## ", 1)[0]
    rows = [line for line in section.splitlines() if line.startswith("| `")]
    return {(m, _normal(p)) for row in rows for m, p in ROUTE.findall(row.split(" | ", 1)[0])}


#: Routes that serve the interactive docs' own assets, not an endpoint anyone calls.
DOCS_ASSETS = re.compile(r"^/docs-assets/|/oauth2-redirect$")


def test_the_endpoint_table_names_every_route_and_only_those() -> None:
    served = {r for r in _app_routes() if not DOCS_ASSETS.search(r[1])}
    documented = _documented_routes()
    assert ("POST", "/v1/analyze") in served and ("GET", "/v1/jobs/{}") in served  # the walk finds routers
    assert sorted(served - documented) == [], "routes the app serves that docs/service.md does not list"
    assert sorted(documented - served) == [], "routes docs/service.md lists that the app does not serve"


def test_the_openapi_description_names_every_job_route() -> None:
    from kfio.service.app import create_app

    app = create_app()
    description = app.openapi()["info"]["description"]
    jobs = sorted(p for m, p in _app_routes() if m == "POST" and re.fullmatch(r"/v1/jobs/[a-z-]+", p))
    assert len(jobs) >= 4
    missing = [p for p in jobs if f"`POST {p}`" not in description]
    assert missing == [], "job routes the OpenAPI description does not name"


def _public() -> list[str]:
    return [n for n in kfio.__all__ if not n.startswith("_")]


def test_python_api_md_names_every_public_name() -> None:
    text = PYTHON_API_MD.read_text(encoding="utf-8")
    named = set(re.findall(r"`(?:kfio\.)?([A-Za-z_][A-Za-z_0-9]*)", text))
    missing = [n for n in _public() if n not in named]
    assert "analyze" in _public() and missing == [], "public names of kfio.__all__ not in docs/python_api.md"


def _functions() -> list[str]:
    out = []
    for name in _public():
        obj = getattr(kfio, name)
        if inspect.isfunction(obj) or (inspect.ismodule(obj) and callable(obj)):
            out.append(name)
    return out


@pytest.mark.parametrize("name", _functions())
def test_help_shows_the_signature_and_an_example(name: str) -> None:
    obj = getattr(kfio, name)
    text = pydoc.render_doc(obj, renderer=pydoc.plaintext)
    target = obj if inspect.isfunction(obj) else obj.__call__
    params = [p for p in inspect.signature(target).parameters if p not in ("self", "args", "kwargs")]
    if inspect.ismodule(obj):  # a callable package (kfio.loop): its help() must show the call
        params = list(inspect.signature(getattr(obj, name)).parameters)
    assert f"{name}(" in text
    if inspect.ismodule(obj):  # the call comes first, before the package's contents
        assert f"kfio.{name}(" in text.split("PACKAGE CONTENTS", 1)[0]
    assert all(p in text for p in params), (name, [p for p in params if p not in text])
    assert ">>>" in text, f"help(kfio.{name}) shows no example"


COUNT = re.compile(r"\b(?:about |runs |holds )?\d[\d,]{2,} (?:tests|test cases)\b|\babout \d[\d,]{2,} in about\b")


@pytest.mark.parametrize("path", [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))], ids=lambda p: p.name)
def test_no_page_states_a_test_count(path: Path) -> None:
    assert COUNT.search("it runs 2711 tests in 2 min") and COUNT.search("the full suite runs about 3200 in about 10")
    text = path.read_text(encoding="utf-8")
    if path.name == "speed-history.md":
        return  # the dated notebook records what each pass measured, counts included
    assert COUNT.findall(text) == []
