"""What the page says, read in Chromium and checked against the reports it shows.

The headline is the exact verdict on every report (a simulation's Monte Carlo
and the bounds are evidence beside it); the design answers of the report are
on the page (Gilbert-Elliott critical rates with the region plot, a Markov
channel's critical parameter, the tail exponent, per-sensor critical values
and advice); numbers are decimals with the exact text on demand; tables fit
at 400 px and 1280 px.  The server, the browser and the helpers are those of
``test_web_browser.py``: Debian's chromium, loopback only, every request to
another host blocked and recorded.
"""

# ruff: noqa: F811  (pytest fixtures imported from test_web_browser are parameters here)

from __future__ import annotations

import math
import re
from fractions import Fraction
from typing import Any

import httpx
import pytest
from test_web_browser import browser_context, load, open_page, server, shot  # noqa: F401  (the fixtures of the browser tests)

from support.live_server import REPO, LiveServer

pytestmark = pytest.mark.slow


def dec(x: float, digits: int = 6) -> str:
    """The page's decimal of ``x`` (``dec`` in report.js) for values in [1e-4, 10**digits)."""
    s = f"{x:.{digits}g}"
    return s.rstrip("0").rstrip(".") if "." in s and "e" not in s else s


def run_example(page: Any, example: str, endpoint: str) -> dict[str, Any]:
    """Load a shipped example, run ``endpoint`` and return the report the page shows."""
    page.select_option("#example", example)
    load(page, lambda: page.click("#load-example"))
    return run(page, endpoint)


def run(page: Any, endpoint: str) -> dict[str, Any]:
    page.click(f"button[data-endpoint={endpoint}]")
    page.wait_for_selector("#verdict", timeout=180_000)
    report: dict[str, Any] = page.evaluate("state.report")
    return report


def analyze_verdict(live: LiveServer, page: Any) -> str:
    """The exact verdict of the request in the page's fields, asked of the API directly."""
    body = page.evaluate("state.requestText")
    r = httpx.post(live.url + "/v1/analyze", content=body, headers={"Content-Type": "application/json"}, timeout=120)
    assert r.status_code == 200, r.text
    verdict: str = r.json()["verdict"]
    return verdict


def headline(page: Any) -> tuple[str, str, str]:
    """(data-verdict, the big word, the line naming where the verdict comes from)."""
    box = page.locator("#verdict")
    return (
        box.get_attribute("data-verdict"),
        box.locator("> strong").inner_text().lower(),
        box.locator(".source").inner_text(),
    )


def test_bursty_gilbert_elliott_simulation_headlines_the_exact_unstable_verdict(
    server: LiveServer,
    browser_context: tuple[Any, list[str]],
) -> None:
    context, outside = browser_context
    outside.clear()
    page = open_page(context, server.url + "/")
    report = run_example(page, "bursty-gilbert-elliott", "simulate")
    st = report["stationary"]
    assert st["verdict"] == "unstable" == analyze_verdict(server, page)  # the report's field, and analyze agrees
    assert report["diverged"] is False  # the sample mean stayed finite: what the old headline read as "stable"
    verdict, word, source = headline(page)
    assert (verdict, word) == ("unstable", "unstable")
    assert "exact verdict" in source and "Theorem 1" in source
    assert not re.search(r"\bstable\b", page.inner_text("#verdict").lower())
    # Monte Carlo beside it, in words, with the exact kappa of the report
    assert st["mean_unreliable"] is True
    evidence = page.inner_text("#monte-carlo")
    assert (
        evidence
        == f"Monte Carlo: sample mean unreliable, kappa = {dec(st['tail_exponent_exact'], 2)}; read the quantiles."
    )
    assert "kappa = 0.44" in evidence
    # the warning is text on the page, visible, not only in the plot's title
    warnings = page.locator("#report .warnings")
    assert warnings.is_visible() and st["warnings"]
    assert [w.strip() for w in warnings.locator("p").all_inner_texts()] == st["warnings"]
    # quantiles, the numbers to read instead of the mean
    rows = page.locator("#report table.quantiles tbody tr").all_inner_texts()
    assert [r.split("\t")[0] for r in rows] == [f"{dec(100 * q['q'], 4)}%" for q in st["quantiles"]]
    shot(page, "bursty-ge-simulate-1280")
    page.set_viewport_size({"width": 400, "height": 900})
    assert page.evaluate("document.documentElement.scrollWidth") <= 400
    shot(page, "bursty-ge-simulate-400")
    assert outside == []


def test_gilbert_elliott_analysis_shows_critical_rates_tail_and_the_region_plot(
    server: LiveServer,
    browser_context: tuple[Any, list[str]],
) -> None:
    context, outside = browser_context
    outside.clear()
    page = open_page(context, server.url + "/")
    plots: list[tuple[str, int, str]] = []
    page.on(
        "response",
        lambda r: plots.append((r.url, r.status, r.headers.get("content-type", ""))) if "/v1/plots/" in r.url else None,
    )
    report = run_example(page, "ge-critical-rates", "analyze")
    assert headline(page)[:2] == (report["verdict"], report["verdict"])
    g = report["gilbert_elliott_region"]
    rec, fail = g["critical_recovery_rate"]["crossings"], g["critical_failure_rate"]["crossings"]
    assert len(rec) == 1 and len(fail) == 1
    answers = page.locator("#ge-critical")
    text = answers.inner_text()
    q_star, p_star = rec[0], fail[0]
    assert f"critical recovery rate q*(p = {report['channel']['failure_rate']})" in text
    assert dec(q_star["value"]) in text and f"({q_star['below']} below, {q_star['above']} above)" in text
    assert f"{dec(p_star['value'])} = {p_star['value_exact']}" in text  # a short exact text is shown beside
    # q*'s radical is at most 24 characters: beside its decimal, as the CLI prints it
    assert len(q_star["value_exact"]) <= 24 and f"{dec(q_star['value'])} = {q_star['value_exact']}" in text
    # the tail exponent and what it implies
    tail, moments = page.inner_text("#tail"), report["tail"]["moments"]
    assert dec(report["tail"]["kappa"], 4) in tail
    assert {"finite": "finite (kappa > 1)", "infinite": "infinite (kappa <= 1)"}[moments["mean"]] in tail
    assert {"finite": "finite (kappa > 2)", "infinite": "infinite (kappa <= 2)"}[moments["variance"]] in tail
    # the region plot, drawn by the plot endpoint (which marks the request's point)
    figure = page.locator("#plots figure")
    assert "the request's point marked" in figure.locator("figcaption").inner_text()
    figure.locator("img").wait_for(timeout=120_000)
    assert figure.locator("img").evaluate("img => img.naturalWidth") > 100
    assert any(u.endswith("/v1/plots/ge-region") and s == 200 and c == "image/png" for u, s, c in plots), plots
    shot(page, "ge-analyze-1280")
    page.set_viewport_size({"width": 400, "height": 900})
    shot(page, "ge-analyze-400")
    assert outside == []


def test_markov_analysis_shows_the_critical_parameter(
    server: LiveServer,
    browser_context: tuple[Any, list[str]],
) -> None:
    context, outside = browser_context
    outside.clear()
    page = open_page(context, server.url + "/")
    report = run_example(page, "markov-order2", "analyze")
    c = report["critical_parameter"]
    assert c is not None and len(c["crossings"]) == 1
    assert c["pointer"] in page.inner_text("#report")
    text = page.inner_text("#critical-parameter")
    x = c["crossings"][0]
    assert dec(x["value"]) in text and f"({x['below']} below, {x['above']} above)" in text
    assert f"{dec(float(Fraction(c['value'])))} = {c['value']}" in text  # the request's value, 0.6 = 3/5
    assert outside == []


def test_per_sensor_analysis_shows_critical_values_and_which_sensor_to_improve(
    server: LiveServer,
    browser_context: tuple[Any, list[str]],
) -> None:
    context, outside = browser_context
    outside.clear()
    page = open_page(context, server.url + "/")
    report = run_example(page, "two-sensors", "analyze")
    regions = report["regions"]
    rows = page.locator("#report table.sensors tbody tr").all_inner_texts()
    assert len(rows) == len(regions["sensors"]) == 2
    for row, s in zip(rows, regions["sensors"]):
        cells = row.split("\t")
        assert cells[0] == s["sensor"]
        assert cells[2] == f"{dec(s['critical_arrival_probability'])} = {s['critical_arrival_probability_exact']}"
    assert [r.split("\t")[2] for r in rows] == ["0.146667 = 11/75", "0.173554 = 21/121"]  # Liu and Goldsmith's 2x2
    imp = regions["sensor_improvement"]
    best = next(s for s in imp["sensors"] if s["sensor"] == imp["best"])
    advice = page.inner_text("#advice")
    assert advice.startswith(f'Improve "{imp["best"]}" first:')
    assert f"from {dec(imp['worst_rate'], 4)} to {dec(best['worst_rate_if_loss_halved'], 4)}" in advice
    improvement = page.locator("#report table.improvement tbody tr").all_inner_texts()
    assert [r.split("\t")[0] for r in improvement] == [s["sensor"] for s in imp["sensors"]]
    page.locator("#plots figure img").wait_for(timeout=120_000)  # the region map of the two probabilities
    assert outside == []


def test_bounds_show_decimals_with_the_exact_text_on_demand_under_the_exact_verdict(
    server: LiveServer,
    browser_context: tuple[Any, list[str]],
) -> None:
    context, outside = browser_context
    outside.clear()
    page = open_page(context, server.url + "/")
    report = run_example(page, "seed004-3x3", "bounds")
    exact_verdict = analyze_verdict(server, page)
    verdict, word, source = headline(page)
    assert (verdict, word) == (exact_verdict, exact_verdict) and "exact verdict" in source
    by_bounds = report["operating_point"]["verdict_by_bounds"]
    assert f"Bounds: {by_bounds}" in page.inner_text("#verdict")
    cp = report["critical_probability"]
    up = cp["upper"]
    assert len(up["exact"]) > 20  # a fraction of the bisection
    bounds = page.locator("#bounds")
    text = bounds.inner_text()
    digits = min(12, max(6, math.ceil(-math.log10(cp["gap"])) + 2))  # enough to tell the bounds apart
    assert dec(up["value"], digits) != dec(cp["lower"]["value"], digits)
    # the decimal first; the fraction beside it when at most 24 characters, else its kind and a toggle
    upper_text = bounds.locator("dd").nth(1).inner_text()
    if len(up["exact"]) <= 24:
        assert upper_text == f"{dec(up['value'], digits)} = {up['exact']}"
    else:
        assert upper_text.startswith(f"{dec(up['value'], digits)} (") and upper_text.endswith("exact")
        assert up["exact"] not in text
        bounds.locator("details.exact summary").first.click()
        assert up["exact"] in bounds.inner_text()
    shot(page, "bounds-3x3-1280")
    page.set_viewport_size({"width": 400, "height": 900})
    shot(page, "bounds-3x3-400")
    # the two-sensor bounds: "135284273913/500000000000 = 0.270569" no more
    page = open_page(context, server.url + "/")
    load(page, lambda: page.set_input_files("#upload", str(REPO / "examples" / "bounds_seed000_two_sensors.json")))
    report = run(page, "bounds")
    uppers = page.locator("#report table.sensors tbody tr td:nth-child(3)").all_inner_texts()
    for cell, s in zip(uppers, report["sensors"]):
        u = s["critical_interval"]["upper"]
        assert cell.startswith(dec(u["value"])) and u["exact"] not in cell
    assert outside == []


FIT = """() => [...document.querySelectorAll('#report table')].map((t) => {
  const wrap = t.closest('.table-wrap');
  const box = wrap.getBoundingClientRect();
  const cells = [...t.tBodies[0].rows].flatMap((r) => [r.cells[r.cells.length - 1],
    ...[...r.cells].filter((c) => c.dataset.label === 'verdict')]);
  return {scroll: wrap.scrollWidth, client: wrap.clientWidth, left: box.left, right: box.right,
          cells: cells.map((c) => { const b = c.getBoundingClientRect();
            return {label: c.dataset.label, left: b.left, right: b.right, width: b.width}; })};
})"""


@pytest.mark.parametrize(
    ("source", "endpoint"),
    [
        ("ge-critical-rates", "analyze"),  # the eight-column block table
        ("two-sensors", "analyze"),  # sensors, improvement and block tables
        ("pendulum_c2d.json", "analyze"),  # eigenvalues as algebraic numbers
        ("seed004-3x3", "bounds"),
    ],
)
def test_tables_fit_at_400_and_1280_px_with_the_verdict_column_visible(
    server: LiveServer,
    browser_context: tuple[Any, list[str]],
    source: str,
    endpoint: str,
) -> None:
    context, outside = browser_context
    outside.clear()
    page = open_page(context, server.url + "/")
    if source.endswith(".json"):
        load(page, lambda: page.set_input_files("#upload", str(REPO / "examples" / source)))
        run(page, endpoint)
    else:
        run_example(page, source, endpoint)
    for width in (1280, 400):
        page.set_viewport_size({"width": width, "height": 900})
        tables = page.evaluate(FIT)
        assert tables, "no table"
        verdict_cells = 0
        for t in tables:
            assert t["scroll"] <= t["client"], (width, t)  # nothing to scroll to: no clipped column
            assert t["right"] <= width + 0.5, (width, t)
            for c in t["cells"]:
                assert c["width"] > 0 and t["left"] - 0.5 <= c["left"] and c["right"] <= t["right"] + 0.5, (width, c, t)
                verdict_cells += c["label"] == "verdict"
        if endpoint == "analyze":
            assert verdict_cells >= 1  # the block table's verdict column, measured
        assert page.evaluate("document.documentElement.scrollWidth") <= width
        shot(page, f"tables-{source.removesuffix('.json')}-{width}")
    assert outside == []


NO_EXACT = """(report) => {
  const problem = {status: 504, title: "Budget exceeded", detail: "the analysis took longer than its budget"};
  const sim = {...report, stationary: {...report.stationary, verdict: null}};
  const out = {};
  for (const [name, node] of [["simulate", renderSimulate(sim, problem)], ["bounds", renderBounds({operating_point: {verdict_by_bounds: "stable"}}, problem)]]) {
    const div = document.createElement("div");
    div.append(node);
    document.body.append(div);
    const box = div.querySelector("#verdict");
    out[name] = {verdict: box.dataset.verdict, word: box.querySelector(":scope > strong").innerText, text: box.innerText};
    div.remove();
  }
  return out;
}"""


def test_where_no_exact_verdict_was_computed_the_headline_says_so(
    server: LiveServer,
    browser_context: tuple[Any, list[str]],
) -> None:
    context, outside = browser_context
    outside.clear()
    page = open_page(context, server.url + "/")
    report = run_example(page, "bursty-gilbert-elliott", "simulate")
    shown = page.evaluate(NO_EXACT, report)  # the page's own renderers, given a report without the exact verdict
    for name in ("simulate", "bounds"):
        assert shown[name]["verdict"] == "none"
        assert shown[name]["word"].lower() == "no exact verdict"
        assert "no exact verdict was computed: the analysis took longer than its budget" in shown[name]["text"]
    assert "Monte Carlo: sample mean unreliable" in shown["simulate"]["text"]  # the evidence stays, as evidence
    assert "Bounds: stable" in shown["bounds"]["text"]
    assert outside == []
