"""The page fits an uploaded trace (POST /v1/fit) and shows the verdict at 95% confidence with its plot.

Server and browser are those of ``tests/service/web/test_web_browser.py`` (Debian's chromium, loopback only).
"""

# ruff: noqa: F811  (pytest fixtures imported from test_web_browser are parameters here)

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import httpx
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "service" / "web"))  # the browser fixtures live there

from test_web_browser import browser_context, open_page, server  # noqa: E402, F401  (fixtures)

from support.live_server import LiveServer  # noqa: E402

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[2]


def test_uploaded_trace_is_fitted_and_the_confidence_verdict_is_shown(
    server: LiveServer, browser_context: tuple[Any, list[str]]
) -> None:
    context, outside = browser_context
    outside.clear()
    page = open_page(context, server.url + "/")
    page.select_option("#example", "seed004-scalar")
    page.click("#load-example")
    page.wait_for_selector('#field-list .field[data-pointer="/channel"]')
    page.set_input_files("#trace-upload", str(ROOT / "examples/traces/near_037.txt"))
    page.wait_for_function("document.querySelector('#trace-note').textContent.includes('packets')")
    note = page.locator("#trace-note").inner_text()
    assert "1000 packets, bernoulli" in note and "arrival_probability = 189/500" in note
    page.click("button[data-endpoint=analyze]")
    page.wait_for_selector("#verdict", timeout=180_000)
    report = page.evaluate("state.report")
    body = page.evaluate("state.requestText")
    r = httpx.post(server.url + "/v1/analyze", content=body, headers={"Content-Type": "application/json"}, timeout=120)
    assert r.status_code == 200 and r.json() == report
    assert report["fit"]["verdict"] == "undecided" and report["fit"]["samples_needed"] == 2807
    text = page.locator("#report").inner_text()
    assert "Verdict at 95% confidence: UNDECIDED" in text and "About 2807 packets" in text
    img = page.locator("#plots figure img")
    img.wait_for(timeout=180_000)
    assert page.evaluate("document.querySelector('#plots figure img').naturalWidth") > 0
    assert outside == []  # nothing was fetched from another host
