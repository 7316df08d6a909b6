"""Every page example x every run button, at 400 px and 1280 px, in Chromium.

The page follows the request: the primary (blue) button is the command that fits the loaded
request (a loop request's is Loop, never Analyze); a button that cannot run it says why on the
page and sends nothing (no round trip, no 422); a button that can run it shows a verdict.  At
both widths the page does not overflow horizontally, plots are shown at no less than 3/4 of their
pixels (their text stays legible; a narrow screen scrolls them), and no Markdown backtick shows.
The example's metadata and the request's own members decide what is expected; the gains' key
names are not read.  Server and browser are those of ``test_web_browser.py``.
"""

# ruff: noqa: F811  (pytest fixtures imported from test_web_browser are parameters here)

from __future__ import annotations

import json
from typing import Any

import pytest
from test_web_browser import browser_context, load, open_page, server, shot  # noqa: F401  (fixtures)

from kfio import load_json
from kfio.model import parse_number

from support.live_server import REPO, LiveServer

pytestmark = pytest.mark.slow

REQUESTS = REPO / "service" / "static" / "requests"
EXAMPLES = json.loads((REQUESTS / "index.json").read_text())
ENDPOINTS = ("analyze", "bounds", "simulate", "loop")
LOOP_MEMBERS = ("actuator_channel", "controller")


def iid(channel: dict[str, Any]) -> bool:
    """Whether a channel's packets are i.i.d., with the validator's own model of it (the bounds need this)."""
    if channel["model"] == "per_sensor":
        return all(iid(c) for c in channel["channels"].values())
    if channel["model"] == "bernoulli":
        return True
    if channel["model"] == "gilbert_elliott":
        return parse_number(channel["failure_rate"], "p") + parse_number(channel["recovery_rate"], "q") == 1
    assert channel["model"] == "markov", f"a new channel model in the examples: teach iid() {channel['model']!r}"
    table = channel.get("arrival_probability", channel)  # a Markov channel's probabilities per history
    values = {parse_number(v, k) for k, v in table.items() if set(k) <= {"0", "1"}}
    return len(values) == 1


def expected_fit(request: dict[str, Any]) -> dict[str, bool]:
    """Which commands can run ``request``, from its members (as the server's validators require)."""
    is_loop = any(k in request for k in LOOP_MEMBERS) or "B" in request["system"]
    noise = {"Q", "R"} <= set(request["system"])
    return {
        "analyze": not is_loop,
        "bounds": not is_loop and noise and iid(request["channel"]),
        "simulate": not is_loop and noise,
        "loop": is_loop and noise,
    }


@pytest.mark.parametrize("width", [400, 1280])
@pytest.mark.parametrize("example", EXAMPLES, ids=lambda e: e["id"])
def test_each_button_runs_or_says_why(
    server: LiveServer, browser_context: tuple[Any, list[str]], example: dict[str, Any], width: int
) -> None:
    context, outside = browser_context
    outside.clear()
    page = open_page(context, server.url + "/", width=width)
    sent: list[str] = []
    page.on("request", lambda r: sent.append(r.url.split("?")[0]) if "/v1/" in r.url else None)
    page.select_option("#example", example["id"])
    load(page, lambda: page.click("#load-example"))
    request = load_json((REQUESTS / f"{example['id']}.json").read_text())  # numbers exact, as the server reads them
    fit = expected_fit(request)
    primary = page.eval_on_selector("fieldset.run button.primary", "b => b.dataset.endpoint")
    if not fit["analyze"] and fit["loop"]:
        assert primary == "loop"  # a loop request's primary command
    else:
        assert primary == example["endpoint"] and fit[primary]
    for endpoint in ENDPOINTS:
        button = page.locator(f"fieldset.run button[data-endpoint={endpoint}]")
        sent.clear()
        if not fit[endpoint]:
            assert button.get_attribute("aria-disabled") == "true"
            reason = button.get_attribute("title")
            assert reason and reason.startswith(f"{endpoint.capitalize()}: ")
            name, why = reason.split(": ", 1)
            note = page.inner_text("#run-note")
            assert why in note and name in note.split(why)[0]  # said once, after the buttons it holds for
            button.click(force=True)  # aria-disabled: Playwright would wait for "enabled"; a person can press it
            status = page.inner_text("#status")
            assert status == f"Not sent: {reason}"
            assert page.inner_text("#general-error") == reason
            assert not any(f"/v1/{endpoint}" in u for u in sent)  # said before any round trip
            continue
        assert button.get_attribute("aria-disabled") is None
        page.evaluate("document.querySelector('#report').replaceChildren()")
        button.click()
        page.wait_for_selector("#verdict", timeout=180_000)
        assert page.inner_text("#status") == f"Done: {endpoint}."
        assert page.get_attribute("#verdict", "data-verdict") in ("stable", "unstable", "boundary", "none")
        text = page.inner_text("#report")
        assert "`" not in text and "Refused" not in text
        if endpoint == primary:  # the plots of the primary command: readable at this width
            page.wait_for_function(
                "[...document.querySelectorAll('#plots figure')].every(f => f.querySelector('img') && "
                "f.querySelector('img').complete && f.querySelector('img').naturalWidth > 0 || "
                "f.querySelector('p.note') && !f.querySelector('p.note').textContent.startsWith('drawing'))",
                timeout=240_000,
            )
            scales = page.eval_on_selector_all(
                "#plots img", "imgs => imgs.map(i => i.getBoundingClientRect().width / i.naturalWidth)"
            )
            assert all(s >= 0.74 for s in scales), scales
        assert page.evaluate("document.documentElement.scrollWidth") <= width
    shot(page, f"buttons-{example['id']}-{width}")
    assert outside == []


def test_a_request_without_noise_gets_fields_to_add_then_bounds_runs(
    server: LiveServer, browser_context: tuple[Any, list[str]]
) -> None:
    """The boundary example has no Q and R: Bounds says so; the added identity fields make it runnable."""
    context, outside = browser_context
    outside.clear()
    page = open_page(context, server.url + "/", width=400)
    page.select_option("#example", "boundary")
    load(page, lambda: page.click("#load-example"))
    bounds = page.locator("fieldset.run button[data-endpoint=bounds]")
    assert (bounds.get_attribute("title") or "").startswith("Bounds: needs /system/Q and /system/R (no default)")
    label = page.locator('#field-list .field[data-pointer="/system/A"] label').inner_text()
    assert "/system/A" in label
    for pointer in ("/system/Q", "/system/R"):
        load(page, lambda pointer=pointer: page.click(f'#add-fields button[data-add="{pointer}"]'))
        area = page.locator(f'#field-list .field[data-pointer="{pointer}"] textarea')
        assert area.input_value() == "[[1]]"  # the identity of the plant's size (A is 1 x 1, C has 1 row)
        help_text = page.locator(f'#field-list .field[data-pointer="{pointer}"] label').inner_text()
        assert "bounds, simulate and loop need it" in help_text and "default identity" not in help_text
    assert page.locator("#add-fields button").count() == 0
    assert bounds.get_attribute("aria-disabled") is None
    bounds.click()
    page.wait_for_selector("#verdict", timeout=180_000)
    assert page.inner_text("#status") == "Done: bounds."
    assert outside == []
