"""The web page and the docs in a real browser: Debian's Chromium, headless, against a real ``kfio serve``.

Playwright for Python drives ``/usr/bin/chromium`` (never a downloaded
browser; install it with ``apt-get install chromium``).  Every request the
page makes to a host other than the server is blocked and recorded, and the
tests assert there were none: the page and ``/docs`` work offline.
Screenshots are kept under ``artifacts/browser/`` (ignored by git).
"""

from __future__ import annotations

import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

import pytest

from support.live_server import REPO, LiveServer, slow_request

CHROMIUM = Path("/usr/bin/chromium")
ARTIFACTS = REPO / "artifacts" / "browser"
FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def server() -> Iterator[LiveServer]:
    with LiveServer(workers=2, env={"KFIO_TIME_BUDGET_S": "60"}) as live:
        yield live


@pytest.fixture(scope="module")
def browser_context(server: LiveServer) -> Iterator[tuple[Any, list[str]]]:
    if not CHROMIUM.exists():
        pytest.fail("Debian's chromium is needed: apt-get install -y chromium chromium-driver")
    from playwright.sync_api import sync_playwright

    outside: list[str] = []
    with tempfile.TemporaryDirectory(prefix="kfio-chromium-") as profile, sync_playwright() as pw:
        context = pw.chromium.launch_persistent_context(
            profile,  # a fresh --user-data-dir
            executable_path=str(CHROMIUM),
            headless=True,
            args=FLAGS,
            viewport={"width": 1280, "height": 900},
            accept_downloads=True,
        )

        def only_loopback(route: Any) -> None:
            host = urlsplit(route.request.url).hostname
            if route.request.url.startswith(("blob:", "data:")) or host == "127.0.0.1":
                route.continue_()
            else:
                outside.append(route.request.url)
                route.abort()

        context.route("**/*", only_loopback)
        try:
            yield context, outside
        finally:
            context.close()


def shot(page: Any, name: str) -> None:
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / f"{name}.png"), full_page=True)


def open_page(context: Any, url: str, width: int = 1280) -> Any:
    page = context.new_page()
    page.set_viewport_size({"width": width, "height": 900})
    page.goto(url)
    page.wait_for_function("Number(document.querySelector('#field-list').dataset.version) >= 1")  # default example
    return page


def load(page: Any, action: Any) -> None:
    """Run ``action`` (which loads a request) and wait until the fields were rebuilt from it."""
    version = page.get_attribute("#field-list", "data-version")
    action()
    page.wait_for_function(f"document.querySelector('#field-list').dataset.version !== '{version}'", timeout=30_000)


def field(page: Any, pointer: str) -> Any:
    return page.locator(f'#field-list .field[data-pointer="{pointer}"]')


def test_seed004_2x2_example_is_stable_with_critical_probability_9_25(
    server: LiveServer, browser_context: tuple[Any, list[str]]
) -> None:
    context, outside = browser_context
    page = open_page(context, server.url + "/")
    page.select_option("#example", "seed004-2x2")
    load(page, lambda: page.click("#load-example"))
    assert field(page, "/system/A").locator("textarea").input_value() == "[[1.25, 0],\n [1, 1.1]]"
    page.click("button[data-endpoint=analyze]")
    page.wait_for_selector("#verdict", timeout=60_000)
    assert page.inner_text("#verdict strong").lower() == "stable"
    report = page.inner_text("#report")
    assert "0.36 = 9/25" in report  # the critical arrival probability, decimal and exact
    assert "1.25 = 5/4" in report and "1.1 = 11/10" in report  # one row per block
    # the phase-transition plot is drawn next to the numbers
    page.wait_for_selector("#plots img", timeout=120_000)
    assert page.eval_on_selector("#plots img", "img => img.naturalWidth") > 100
    assert page.input_value("#kfio-cmd") == "kfio analyze --json request.json"
    curl = page.input_value("#curl-cmd")
    assert curl.startswith(f"curl -s {server.url}/v1/analyze -H 'Content-Type: application/json'")
    with page.expect_download() as download:
        page.click("#download")
    assert '"critical_arrival_probability_exact": "9/25"' in Path(download.value.path()).read_text()
    shot(page, "seed004-2x2-1280")
    page.set_viewport_size({"width": 400, "height": 900})
    assert page.evaluate("document.documentElement.scrollWidth") <= 400  # readable without sideways scrolling
    shot(page, "seed004-2x2-400")
    assert outside == []


def test_bad_input_is_shown_beside_its_field(server: LiveServer, browser_context: tuple[Any, list[str]]) -> None:
    context, outside = browser_context
    page = open_page(context, server.url + "/")
    page.select_option("#example", "seed004-2x2")
    load(page, lambda: page.click("#load-example"))
    q = field(page, "/system/Q")
    q.locator("textarea").fill("[[20, 0], [0, -20]]")  # not positive semidefinite
    page.click("button[data-endpoint=analyze]")
    error = q.locator(".field-error")
    error.wait_for(state="visible", timeout=60_000)
    assert error.inner_text().startswith("/system/Q")
    assert q.locator("textarea").get_attribute("aria-invalid") == "true"
    # the other fields carry no message, and the focus went to the field at fault
    assert page.locator("#field-list .field-error:visible").count() == 1
    assert page.evaluate("document.activeElement.closest('.field').dataset.pointer") == "/system/Q"
    shot(page, "bad-input-system-Q")
    # a field that is not JSON is caught before sending, beside the field too
    a = field(page, "/system/A")
    a.locator("textarea").fill("[[1.25, 0], [1, 1.1]")
    page.click("button[data-endpoint=analyze]")
    assert "not valid JSON" in a.locator(".field-error").inner_text()
    assert outside == []


def test_keyboard_only_run(server: LiveServer, browser_context: tuple[Any, list[str]]) -> None:
    context, outside = browser_context
    page = open_page(context, server.url + "/")
    page.focus("#example")
    page.keyboard.press("End")  # the last example: on the boundary
    page.keyboard.press("Tab")
    load(page, lambda: page.keyboard.press("Enter"))  # Load example
    assert "21/121" in page.inner_text("#example-note")
    page.focus("button[data-endpoint=analyze]")
    page.keyboard.press("Enter")
    page.wait_for_selector("#verdict", timeout=60_000)
    assert page.inner_text("#verdict strong").lower() == "boundary"
    assert outside == []


def test_docs_and_redoc_work_offline(server: LiveServer, browser_context: tuple[Any, list[str]]) -> None:
    context, outside = browser_context
    outside.clear()
    page = context.new_page()
    page.goto(server.url + "/docs")
    page.wait_for_selector(".opblock", timeout=60_000)
    summaries = page.locator(".opblock-summary-path").all_inner_texts()
    for path in ("/v1/analyze", "/v1/bounds", "/v1/simulate", "/v1/jobs/analyze", "/v1/jobs/{job_id}"):
        assert any(s.replace("\u200b", "") == path for s in summaries), (path, summaries)
    shot(page, "docs")
    assert outside == []
    page.goto(server.url + "/redoc")
    page.locator("h2", has_text="Exact stability verdict").first.wait_for(timeout=60_000)  # an operation
    page.get_by_text("API docs by Redocly").wait_for(timeout=60_000)  # the sidebar footer whose logo came from a CDN
    shot(page, "redoc")
    assert page.locator('img[alt="redocly logo"][src^="http"]').count() == 0
    assert outside == []


def test_long_work_as_a_job_shows_progress_and_can_be_cancelled(
    server: LiveServer, browser_context: tuple[Any, list[str]]
) -> None:
    context, outside = browser_context
    outside.clear()
    page = open_page(context, server.url + "/")
    page.check("#as-job")
    page.click("button[data-endpoint=analyze]")  # the default example, through the job lane
    page.wait_for_selector("#verdict", timeout=60_000)
    assert page.inner_text("#verdict strong").lower() == "stable" and "0.36 = 9/25" in page.inner_text("#report")
    # a simulation of minutes, pasted in: the job reports its progress, and Cancel stops it
    page.click("#paste-box summary")
    page.fill("#paste", slow_request(seed=21).decode())
    load(page, lambda: page.click("#use-paste"))
    page.click("button[data-endpoint=simulate]")
    page.wait_for_function("document.querySelector('#job-progress').value > 0", timeout=120_000)
    assert "Monte Carlo simulation" in page.inner_text("#job-text")
    shot(page, "job-running")
    page.click("#job-cancel")
    page.wait_for_function("document.querySelector('#status').textContent.includes('cancelled')", timeout=60_000)
    assert page.locator("#job-box").is_hidden()
    assert outside == []


def test_an_uploaded_two_sensor_request_gets_its_region_map(
    server: LiveServer, browser_context: tuple[Any, list[str]]
) -> None:
    context, outside = browser_context
    outside.clear()
    page = open_page(context, server.url + "/")
    load(page, lambda: page.set_input_files("#upload", str(REPO / "examples" / "bounds_seed000_two_sensors.json")))
    page.click("button[data-endpoint=bounds]")
    page.wait_for_selector("#verdict", timeout=60_000)
    assert page.inner_text("#verdict strong").lower() in {"stable", "unstable", "undecided"}
    rows = page.locator("#report table").first.locator("tbody tr").all_inner_texts()
    assert [r.split("\t")[0] for r in rows] == ["first", "second"]  # one row of bounds per sensor
    figure = page.locator("#plots figure")
    assert "Liu and Goldsmith 2004" in figure.locator("figcaption").inner_text()
    figure.locator("img").wait_for(timeout=120_000)
    shot(page, "two-sensors-bounds")
    assert outside == []
