"""The loop region plot draws what the loop report says: read back from the figure's artists.

The scalar loop of ``examples/loop_scalar.json`` (TCP-like, fixed gains):
the cells of the map, the boundary line, the dashed critical values and
the cost curves are compared with :func:`kfio.loop.analyze_loop`'s report
and with the scalar closed form of the estimator's verdict.
"""

from __future__ import annotations

import json
import time
from fractions import Fraction
from typing import Iterator

import numpy as np
import pytest
from fastapi.testclient import TestClient

from kfio.loop import analyze_loop, load_loop_request
from kfio.service.app import create_app
from kfio.service.loop_plot import (
    ACTUATOR_COST_GID,
    BOUNDARY_GID,
    SENSOR_COST_GID,
    loop_region_data,
    loop_region_figure,
)
from kfio.service.settings import Settings

from support.paths import ROOT

EXAMPLE = json.loads((ROOT / "examples" / "loop_scalar.json").read_text())
POINTS = 5


def _request(**loop: object) -> object:
    body = {**EXAMPLE, "options": {"loop": {**EXAMPLE["options"]["loop"], **loop}}}
    return load_loop_request(json.dumps(body))


@pytest.fixture(scope="module")
def drawn() -> tuple[dict, object]:
    data = loop_region_data(_request(), POINTS)
    return data, loop_region_figure(data)


@pytest.fixture(scope="module")
def report() -> dict:
    return analyze_loop(_request(region=POINTS)).to_dict()


def _line(ax, gid: str) -> np.ndarray:
    (line,) = [ln for ln in ax.get_lines() if ln.get_gid() == gid]
    return np.asarray(line.get_xydata(), dtype=float)


def test_headline_is_the_reports_exact_verdict_cost_and_critical_values(drawn, report) -> None:
    _, fig = drawn
    title = fig._suptitle.get_text()
    first = title.splitlines()[0]
    assert first.startswith(f"{report['verdict'].upper()} (exact")
    assert "sensor arrival probability 0.8, actuator arrival probability 0.9" in " ".join(title.split())  # wrapped
    assert f"stationary cost {report['cost']:.6g}" in title
    assert f"critical sensor arrival probability {report['critical_sensor_arrival_probability_exact']}" in title
    assert f"critical actuator arrival probability {report['critical_actuator_arrival_probability_exact']}" in title


def test_boundary_line_is_the_reports_region_boundary(drawn, report) -> None:
    _, fig = drawn
    pts = _line(fig.axes[0], BOUNDARY_GID)
    rows = report["region"]["boundary"]
    assert len(pts) == len(rows) == POINTS
    np.testing.assert_array_equal(pts[:, 0], [r["sensor_arrival_probability"] for r in rows])
    want = [
        np.nan if r["critical_actuator_arrival_probability"] is None else r["critical_actuator_arrival_probability"]
        for r in rows
    ]
    np.testing.assert_array_equal(pts[:, 1], want)
    assert np.isfinite(pts[:, 1]).any() and np.isnan(pts[:, 1]).any()  # both sides of the sensor's critical value


def test_cells_agree_with_the_boundary_and_the_scalar_closed_form(drawn, report) -> None:
    data, fig = drawn
    codes = np.asarray(fig.axes[0].images[0].get_array()).T  # back to codes[sensor][actuator]
    rows = report["region"]["boundary"]
    a, k, c = Fraction(5, 4), Fraction(1, 2), Fraction(1)
    for i, x in enumerate(data["centres"]):
        lam = Fraction(2 * i + 1, 2 * POINTS)
        # the fixed-gain estimator alone: stable iff lam (a - k c)^2 + (1 - lam) a^2 < 1 (TCP-like: separation)
        estimator_ok = lam * (a - k * c) ** 2 + (1 - lam) * a**2 < 1
        nu_c = rows[i]["critical_actuator_arrival_probability"]
        assert (nu_c is not None) == estimator_ok
        for j, y in enumerate(data["centres"]):
            assert codes[i][j] == (1.0 if nu_c is not None and y > nu_c else -1.0), (x, y)


def test_dashed_critical_values_are_the_reports(drawn, report) -> None:
    _, fig = drawn
    top, bottom = fig.axes[:2]
    crit_s = report["critical_sensor_arrival_probability"]
    crit_a = report["critical_actuator_arrival_probability"]
    xs = sorted(ln.get_xdata()[0] for ln in bottom.get_lines() if ln.get_linestyle() == "--")
    assert xs == sorted([crit_s, crit_a])
    dashed = [np.asarray(ln.get_xydata()) for ln in top.get_lines() if ln.get_linestyle() == "--"]
    assert {float(d[0, 0]) for d in dashed if d[0, 0] == d[1, 0]} == {crit_s}
    assert {float(d[0, 1]) for d in dashed if d[0, 1] == d[1, 1]} == {crit_a}


def test_cost_curves_are_the_exact_cost_finite_exactly_above_the_critical_value(drawn, report) -> None:
    _, fig = drawn
    bottom = fig.axes[1]
    for gid, key, held in (
        (SENSOR_COST_GID, "critical_sensor_arrival_probability", 0.8),
        (ACTUATOR_COST_GID, "critical_actuator_arrival_probability", 0.9),
    ):
        pts = _line(bottom, gid)
        assert (np.isfinite(pts[:, 1]) == (pts[:, 0] > report[key])).all()
        at = np.flatnonzero(np.isclose(pts[:, 0], held))
        assert len(at) == 1 and pts[at[0], 1] == report["cost"]  # the request's own point: the report's cost
    # one more point off the request, against the report of that loop
    pts = _line(bottom, ACTUATOR_COST_GID)
    k = int(np.flatnonzero(np.isclose(pts[:, 0], 0.7))[0])
    body = {**EXAMPLE, "actuator_channel": {"model": "bernoulli", "arrival_probability": "7/10"}}
    assert pts[k, 1] == analyze_loop(load_loop_request(json.dumps(body))).cost


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with TestClient(create_app(Settings(workers=1, time_budget_s=20))) as c:
        for _ in range(1200):  # bounded by count, not by the clock
            if c.get("/readyz").status_code == 200:
                break
            time.sleep(0.05)
        yield c


@pytest.mark.slow
def test_http_plot_is_png_and_bad_bodies_are_422(client: TestClient) -> None:
    r = client.post(f"/v1/plots/loop-region?points={POINTS}", json=EXAMPLE)
    assert r.status_code == 200, r.text
    assert r.headers["content-type"] == "image/png" and r.content.startswith(b"\x89PNG\r\n\x1a\n")
    no_b = {**EXAMPLE, "system": {k: v for k, v in EXAMPLE["system"].items() if k != "B"}}
    r = client.post("/v1/plots/loop-region", json=no_b)
    assert r.status_code == 422 and "/system" in r.json()["field"]
    table = {"0": "1/2", "1": "3/4"}
    markov = {**EXAMPLE, "actuator_channel": {"model": "markov", "order": 1, "arrival_probability": table}}
    r = client.post("/v1/plots/loop-region", json=markov)
    assert r.status_code == 422 and r.json()["field"] == "/actuator_channel/model", r.text


def test_gilbert_elliott_actuator_is_a_map_of_exact_verdicts_with_the_reports_critical_rate() -> None:
    body = {
        **EXAMPLE,
        "channel": {"model": "bernoulli", "arrival_probability": "7/10"},  # a cell centre of the map
        "actuator_channel": {"model": "gilbert_elliott", "failure_rate": "1/10", "recovery_rate": "3/5"},
        "options": {"loop": {"protocol": "udp", "on_loss": "zero"}},
    }
    req = load_loop_request(json.dumps(body))
    data = loop_region_data(req, POINTS)
    fig = loop_region_figure(data)
    report = analyze_loop(req).to_dict()
    assert data["boundary"] is None and not [ln for ln in fig.axes[0].get_lines() if ln.get_gid() == BOUNDARY_GID]
    (actuator,) = [c for c in report["critical_values"] if c["link"] == "actuator"]
    assert actuator["parameter"].endswith("recovery_rate") and actuator["value"] is not None
    dashed = [np.asarray(ln.get_xydata()) for ln in fig.axes[0].get_lines() if ln.get_linestyle() == "--"]
    assert {float(d[0, 1]) for d in dashed if d[0, 1] == d[1, 1]} == {actuator["value"]}
    assert "critical actuator recovery rate" in fig._suptitle.get_text()
    # the column of cells through the request's sensor probability switches at the report's critical rate
    codes = np.asarray(fig.axes[0].images[0].get_array()).T
    i = data["centres"].index(0.7)
    assert set(codes[i]) == {1.0, -1.0}  # both sides are on the map
    for j, q in enumerate(data["centres"]):
        assert codes[i][j] == (1.0 if q > actuator["value"] else -1.0)
