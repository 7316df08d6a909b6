"""The page at ``/``, ``/docs`` and ``/redoc`` reference no other host; the shipped examples are valid requests."""

from __future__ import annotations

import json
import re
from urllib.parse import urlsplit

import pytest
from fastapi.testclient import TestClient

from kfio import load_request
from kfio.service.app import create_app
from kfio.service.settings import Settings

from support.live_server import REPO

URL_ATTR = re.compile(r"""(?:src|href|url)\s*[=:(]\s*['"]?([^'"\s>)]+)""", re.IGNORECASE)
ABSOLUTE = re.compile(r"""https?://[^\s'"<>]+|['"(]//[a-z0-9-]+\.[a-z]""", re.IGNORECASE)  # with scheme, or //host


@pytest.fixture(scope="module")
def client() -> TestClient:
    return TestClient(create_app(Settings()))  # no lifespan: static pages need no workers


@pytest.mark.parametrize("path", ["/", "/docs", "/redoc", "/docs/oauth2-redirect", "/static/app.js", "/static/app.css"])
def test_pages_and_assets_reference_no_external_host(client: TestClient, path: str) -> None:
    r = client.get(path)
    assert r.status_code == 200
    text = r.text
    assert not ABSOLUTE.findall(text), ABSOLUTE.findall(text)
    for ref in URL_ATTR.findall(text):
        parts = urlsplit(ref)
        assert not parts.netloc and parts.scheme in ("", "data", "blob"), ref


def test_docs_pages_load_their_assets_from_this_server(client: TestClient) -> None:
    docs, redoc = client.get("/docs").text, client.get("/redoc").text
    for asset in ("/docs-assets/swagger-ui-bundle.js", "/docs-assets/swagger-ui.css"):
        assert asset in docs and client.get(asset).status_code == 200
    assert "/docs-assets/redoc.standalone.js" in redoc and "fonts.googleapis" not in redoc
    assert client.get("/docs-assets/redoc.standalone.js").status_code == 200
    page = client.get("/").text
    for asset in re.findall(r'(?:src|href)="(/[^"]+)"', page):
        if not asset.startswith(("/docs", "/redoc")):
            assert client.get(asset).status_code == 200, asset


def test_shipped_examples_are_valid_requests_matching_the_repository_examples(client: TestClient) -> None:
    index = client.get("/static/requests/index.json").json()
    ids = {e["id"] for e in index}
    assert {"seed004-2x2", "bursty-gilbert-elliott", "two-sensors", "seed004-scalar"} <= ids
    for example in index:
        assert example["endpoint"] in {"analyze", "bounds", "simulate"}
        body = client.get(f"/static/requests/{example['id']}.json").content
        load_request(body)  # raises on an invalid request
    # the 2x2 example is the one of the browser test: A = [[1.25, 0], [1, 1.1]], C = [1 1], Q = 20 I, R = 2.5
    two_by_two = json.loads(client.get("/static/requests/seed004-2x2.json").content)
    assert two_by_two == json.loads((REPO / "examples" / "bounds_seed004_2x2.json").read_text())
