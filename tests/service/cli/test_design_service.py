"""The design answers through the shells: the GE region plot endpoint, the CLI options, the report fields."""

from __future__ import annotations

import json
from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient

from kfio.service.api.schemas import REQUEST_EXAMPLES
from kfio.service.cli import main as cli_main
from kfio.service.settings import Settings

from support.app_client import ready_client

GE_BODY = REQUEST_EXAMPLES["seed001-degenerate-gilbert-elliott"]["value"]
PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with ready_client(Settings(workers=1, time_budget_s=30), timeout=30) as c:
        yield c


def test_ge_region_plot_is_png(client: TestClient) -> None:
    r = client.post("/v1/plots/ge-region?points=11", json=GE_BODY)
    assert r.status_code == 200, r.text
    assert r.headers["content-type"] == "image/png" and r.content.startswith(PNG)


def test_ge_region_plot_refuses_bernoulli(client: TestClient) -> None:
    r = client.post("/v1/plots/ge-region", json=REQUEST_EXAMPLES["seed004-scalar"]["value"])
    assert r.status_code == 422 and r.json()["field"] == "/channel/model"


def test_ge_grid_out_of_range_is_422(client: TestClient) -> None:
    body = {**GE_BODY, "options": {"analyze": {"ge_grid": 500}}}
    r = client.post("/v1/analyze", json=body)
    assert r.status_code == 422 and r.json()["field"] == "/options/analyze/ge_grid"


def test_analyze_over_http_has_tail_and_ge_fields(client: TestClient) -> None:
    r = client.post("/v1/analyze", json={**GE_BODY, "options": {"analyze": {"ge_grid": 5}}})
    assert r.status_code == 200, r.text
    d = r.json()
    assert d["tail"]["blocks"][0]["basis"] == "extension"  # degenerate block
    g = d["gilbert_elliott_region"]
    assert g["critical_recovery_rate"]["fixed"] == "1/10" and len(g["map"]["labels"]) == 5


def test_cli_ge_grid_and_plot(tmp_path, capsys) -> None:
    path = tmp_path / "req.json"
    path.write_text(json.dumps(GE_BODY))
    png = tmp_path / "ge.png"
    code = cli_main(["analyze", "--json", "--ge-grid", "7", "--ge-plot", str(png), str(path)])
    out = json.loads(capsys.readouterr().out)
    assert code in (0, 1, 3) and len(out["gilbert_elliott_region"]["map"]["rates"]) == 7
    assert png.read_bytes().startswith(PNG)
    assert cli_main(["analyze", "--ge-grid", "1", str(path)]) == 2
    assert "/options/analyze/ge_grid" in capsys.readouterr().err
