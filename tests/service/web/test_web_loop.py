"""The page's Loop command, read in Chromium and checked against the loop report.

The shipped loop example (``examples/loop_scalar.json``) is loaded and run
with the Loop button: the headline is the exact verdict of the report the
API returns for the same body, the cost and both critical probabilities are
shown as the report's decimals with their exact texts, the estimator-alone
sentence is the report's, and the region plot is drawn.  Server and browser
are those of ``test_web_browser.py`` (Debian's chromium, loopback only).
"""

# ruff: noqa: F811  (pytest fixtures imported from test_web_browser are parameters here)

from __future__ import annotations

import json
from typing import Any

import httpx
import pytest
from test_web_answers import dec, headline, run_example
from test_web_browser import ARTIFACTS, browser_context, open_page, server  # noqa: F401  (fixtures)

from support.live_server import LiveServer

pytestmark = pytest.mark.slow


def test_loop_example_headlines_the_exact_verdict_and_shows_the_reports_numbers(
    server: LiveServer, browser_context: tuple[Any, list[str]]
) -> None:
    context, outside = browser_context
    outside.clear()
    page = open_page(context, server.url + "/")
    shown = run_example(page, "loop-scalar", "loop")
    body = page.evaluate("state.requestText")
    r = httpx.post(server.url + "/v1/loop", content=body, headers={"Content-Type": "application/json"}, timeout=120)
    assert r.status_code == 200, r.text
    report = r.json()
    assert shown == report  # the page shows the API's report for the body it sent
    assert json.loads(body)["actuator_channel"]["arrival_probability"] == 0.9

    verdict, word, source = headline(page)
    assert verdict == word == report["verdict"]
    assert "exact verdict" in source and "Costa, Fragoso and Marques 2005" in source

    facts = page.locator("#loop").inner_text()
    cost = report["cost"]
    assert cost is not None and dec(cost) in facts
    for key in ("critical_sensor_arrival_probability", "critical_actuator_arrival_probability"):
        exact, value = report[f"{key}_exact"], report[key]
        assert f"{dec(value)} = {exact}" in facts  # short exact text beside the decimal
    # the cost's exact fraction, at most 24 characters, beside its decimal (a longer one: behind "exact")
    assert len(report["cost_exact"]) <= 24 and f"{dec(cost)} = {report['cost_exact']}" in facts

    statement = report["estimator_alone"]["statement"]
    assert statement and statement in page.locator("#estimator-alone").inner_text().lower()

    img = page.locator("#plots figure img")
    img.wait_for(timeout=180_000)
    assert page.evaluate("document.querySelector('#plots figure img').naturalWidth") > 0
    assert page.locator("#kfio-cmd").input_value() == "kfio loop --json request.json"
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    page.locator("#results").screenshot(path=str(ARTIFACTS / "web-loop.png"))
    assert outside == []


@pytest.mark.parametrize("example", ["loop-lqg", "loop-udp"])
def test_lqg_and_udp_bounds_are_shown_as_the_report_has_them(
    server: LiveServer, browser_context: tuple[Any, list[str]], example: str
) -> None:
    context, outside = browser_context
    outside.clear()
    page = open_page(context, server.url + "/")
    report = run_example(page, example, "loop")
    verdict, word, _ = headline(page)
    assert verdict == word == report["verdict"]  # the exact verdict first, the bounds below it
    if example == "loop-lqg":
        facts = page.locator("#loop-lqg").inner_text()
        optimal = report["lqg"]["optimal"]
        bounds = optimal["cost_bounds"]
        assert f"between {dec(bounds['lower'])} and {dec(bounds['upper'])}" in facts
        value = optimal["critical_actuator_arrival_probability"]
        assert optimal["critical_actuator_arrival_probability_exact"] == "9/25" and f"{dec(value)} = 9/25" in facts
        assert page.locator("#loop-udp").count() == 0
    else:
        outer = report["udp_region_bounds"]["outer"]
        facts = page.locator("#loop-udp").inner_text()
        for link in ("sensor", "actuator"):
            exact, value = outer[f"{link}_arrival_probability_above_exact"], outer[f"{link}_arrival_probability_above"]
            assert f"above {dec(value)} = {exact}" in facts
        assert page.locator("#loop-lqg").count() == 0
    assert outside == []
