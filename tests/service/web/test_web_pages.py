"""The page at ``/``, ``/docs`` and ``/redoc`` reference no other host; the shipped examples are valid requests."""

from __future__ import annotations

import json
import re
from urllib.parse import urlsplit

import pytest
from fastapi.testclient import TestClient

from kfio import load_request
from kfio.loop import load_loop_request
from kfio.service.api import web
from kfio.service.app import create_app
from kfio.service.settings import Settings

from support.live_server import REPO

URL_ATTR = re.compile(r"""(?:src|href|url)\s*[=:(]\s*['"]?([^'"\s>)]+)""", re.IGNORECASE)
ABSOLUTE = re.compile(r"""https?://[^\s'"<>]+|['"(]//[a-z0-9-]+\.[a-z]""", re.IGNORECASE)  # with scheme, or //host
#: What makes a browser load from another host, in a script or style sheet: an address given to src, url(),
#: @import, fetch or importScripts, an address of an image, font, script or style sheet, a web-font service.
#: (Bundles also hold addresses nothing loads: XML namespaces, JSON Schema ids, links in error messages.)
LOADS = re.compile(
    r"""(?:\bsrc\s*[:=]\s*|url\(\s*|@import\s+|\bfetch\(\s*|importScripts\(\s*)["'`]?(?:https?:)?//[a-z0-9][^\s'"`<>()]*"""
    r"""|https?://[^\s'"`<>()]+\.(?:svg|png|jpe?g|gif|ico|webp|woff2?|ttf|otf|eot|css|js)(?=[?#'"`\s)]|$)"""
    r"""|fonts\.(?:googleapis|gstatic)\.com""",
    re.IGNORECASE,
)
PAGES = ["/", "/docs", "/redoc", "/docs/oauth2-redirect"]


@pytest.fixture(scope="module")
def client() -> TestClient:
    return TestClient(create_app(Settings()))  # no lifespan: static pages need no workers


def assets_of(client: TestClient, page: str) -> list[str]:
    """The local addresses a page's HTML loads (scripts, style sheets, icons)."""
    html = client.get(page).text
    return [ref for ref in URL_ATTR.findall(html) if ref.startswith("/") and not ref.startswith("//")]


def served_texts(client: TestClient) -> dict[str, str]:
    """Every page and every script or style sheet the pages load, as served."""
    texts = {}
    for page in PAGES:
        texts[page] = client.get(page).text
        for asset in assets_of(client, page):
            if asset.endswith((".js", ".css")):
                texts[asset] = client.get(asset).text
    return texts


def test_the_crawl_reaches_every_script_and_style_sheet(client: TestClient) -> None:
    texts = served_texts(client)
    for asset in (
        "/static/app.js",
        "/static/report.js",
        "/static/app.css",
        "/docs-assets/swagger-ui-bundle.js",
        "/docs-assets/swagger-ui.css",
        "/docs-assets/redoc.standalone.js",
    ):
        assert asset in texts and len(texts[asset]) > 1000, asset


@pytest.mark.parametrize("path", PAGES + ["/static/app.js", "/static/report.js", "/static/app.css"])
def test_pages_and_own_assets_reference_no_external_host(client: TestClient, path: str) -> None:
    r = client.get(path)
    assert r.status_code == 200
    text = r.text
    assert not ABSOLUTE.findall(text), ABSOLUTE.findall(text)
    for ref in URL_ATTR.findall(text):
        parts = urlsplit(ref)
        assert not parts.netloc and parts.scheme in ("", "data", "blob"), ref


def test_no_served_page_or_asset_loads_from_another_host(client: TestClient) -> None:
    found = {path: LOADS.findall(text) for path, text in served_texts(client).items()}
    assert all(not hits for hits in found.values()), {p: h for p, h in found.items() if h}


def test_the_scan_catches_redocs_cdn_logo_and_the_served_bundle_has_none(client: TestClient) -> None:
    vendor = (web._docs_assets() / "redoc.standalone.js").read_text()
    assert any("cdn.redoc.ly" in hit for hit in LOADS.findall(vendor))  # the scan above would fail on it
    served = client.get("/docs-assets/redoc.standalone.js")
    assert served.headers["content-type"].startswith("text/javascript")
    assert "cdn.redoc.ly" not in served.text
    assert len(served.text) == len(vendor) - len(web.REDOC_LOGO)  # only the logo's address was taken out


def test_swagger_ui_is_given_no_online_validator(client: TestClient) -> None:
    # the bundle's default validatorUrl is another host; kfio's layout draws no badge, and null keeps it so
    assert "validator.swagger.io" in client.get("/docs-assets/swagger-ui-bundle.js").text
    assert re.search(r'"validatorUrl":\s*null', client.get("/docs").text)


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
        assert example["endpoint"] in {"analyze", "bounds", "simulate", "loop"}
        body = client.get(f"/static/requests/{example['id']}.json").content
        if example["endpoint"] == "loop":  # a loop request (docs/loop.md), the repository example
            load_loop_request(body)  # raises on an invalid loop request
            repo_example = REPO / "examples" / f"{example['id'].replace('-', '_')}.json"  # loop-lqg: loop_lqg.json
            assert json.loads(body) == json.loads(repo_example.read_text())
        else:
            load_request(body)  # raises on an invalid request
    # the 2x2 example is the one of the browser test: A = [[1.25, 0], [1, 1.1]], C = [1 1], Q = 20 I, R = 2.5
    two_by_two = json.loads(client.get("/static/requests/seed004-2x2.json").content)
    assert two_by_two == json.loads((REPO / "examples" / "bounds_seed004_2x2.json").read_text())
