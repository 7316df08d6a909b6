"""The doors of kfio fit: ``kfio fit`` (exit 0 / 2), ``kfio analyze|loop --trace``, POST /v1/fit (200 / 422),
trace channels in POST /v1/analyze, and ``kfio.fit`` giving the same JSON."""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

import kfio
from kfio.service.cli import main as cli_main
from kfio.service.settings import Settings

from support.app_client import ready_client
from support.traces import simulate_chain

ROOT = Path(__file__).resolve().parents[2]
PLANT = {"system": {"A": [["5/4"]], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": 0.5}}


def _lines(a: np.ndarray) -> str:
    return "\n".join(map(str, a.tolist())) + "\n"


def _exact(ones: int, n: int) -> np.ndarray:
    a = np.zeros(n, dtype=np.uint8)
    a[:ones] = 1
    np.random.default_rng(1).shuffle(a)
    return a


@pytest.fixture
def files(tmp_path: Path) -> Path:
    (tmp_path / "plant.json").write_text(json.dumps(PLANT))
    (tmp_path / "long.txt").write_text(_lines(_exact(12_000, 20_000)))
    (tmp_path / "near.txt").write_text(_lines(_exact(370, 1_000)))
    (tmp_path / "bursty.txt").write_text(_lines(simulate_chain((0.3, 0.95), 20_000, 1)))
    (tmp_path / "bad.txt").write_text("1\n0\n2\n")
    (tmp_path / "seq.txt").write_text("1\n2\n4\n3\n4\n7\n")
    (tmp_path / "log.csv").write_text("t,gps,imu\n" + "".join(f"{i},{i % 3 > 0:d},{i % 4 > 0:d}\n" for i in range(40)))
    return tmp_path


def test_cli_fit_json_equals_the_python_report(files: Path, capsys) -> None:
    assert cli_main(["fit", str(files / "bursty.txt"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    a = np.array([int(x) for x in (files / "bursty.txt").read_text().split()], dtype=np.uint8)
    assert out == kfio.fit(a).to_dict()
    assert out["model"] == "gilbert_elliott"
    assert kfio.gilbert_elliott(**{k: v for k, v in out["channel"].items() if k != "model"}).order == 1


def test_cli_fit_summary_sequence_and_columns(files: Path, capsys) -> None:
    assert cli_main(["fit", str(files / "bursty.txt")]) == 0
    text = capsys.readouterr().out
    assert "model: gilbert_elliott" in text and "BIC bernoulli" in text
    assert cli_main(["fit", "--sequence", str(files / "seq.txt"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["samples"] == 7 and out["sequence"]["duplicates"] == 1 and out["sequence"]["reordered"] == 1
    assert cli_main(["fit", str(files / "log.csv"), "--column", "gps", "--column", "imu", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out["fits"]) == {"gps", "imu"} and out["channel"]["model"] == "per_sensor"


@pytest.mark.parametrize(
    ("argv", "field"),
    [
        (["fit", "bad.txt"], "bad.txt line 3"),
        (["fit", "missing.txt"], "missing.txt"),
        (["fit", "long.txt", "--level", "1.5"], "--level"),
        (["fit", "long.txt", "--model", "markov"], "--order"),
        (["fit", "log.csv", "--column", "radar"], "--column"),
        (["fit", "seq.txt", "--sequence", "--window", "-1"], "--window"),
        (["analyze", "plant.json", "--level", "0.9"], "--level"),
    ],
)
def test_cli_bad_input_exits_2_naming_the_field(files: Path, capsys, monkeypatch, argv, field) -> None:
    monkeypatch.chdir(files)
    assert cli_main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"kfio: invalid input at {field}:"), err


def test_cli_one_symbol_and_too_short(files: Path, capsys) -> None:
    (files / "ones.txt").write_text("1\n1\n1\n")
    assert cli_main(["fit", str(files / "ones.txt")]) == 2
    assert "only arrivals" in capsys.readouterr().err
    (files / "short.txt").write_text("0\n1\n1\n0\n1\n")
    assert cli_main(["fit", str(files / "short.txt"), "--model", "markov", "--order", "4"]) == 2
    assert "at least 20 packets" in capsys.readouterr().err


def test_cli_analyze_trace_stable_and_undecided(files: Path, capsys) -> None:
    assert cli_main(["analyze", str(files / "plant.json"), "--trace", str(files / "long.txt"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["verdict"] == "stable" and out["fit"]["verdict"] == "stable" and out["fit"]["samples_needed"] is None
    assert out["channel"]["arrival_probability"] == "3/5"
    assert cli_main(["analyze", str(files / "plant.json"), "--trace", str(files / "near.txt")]) == 0
    text = capsys.readouterr().out
    assert "at 95% confidence: UNDECIDED" in text and "packets in all would decide" in text


def test_cli_trace_whose_fit_leaves_assumption_1_is_refused_naming_the_trace(files: Path, capsys) -> None:
    # every loss followed by an arrival: the maximum-likelihood recovery rate is exactly 1, outside
    # Assumption 1 of Rohr, Marelli and Fu (2014); the request door says so at /channel/arrivals
    edge = files / "edge.txt"
    edge.write_text("\n".join("110" * 40) + "\n")
    assert cli_main(["analyze", str(files / "plant.json"), "--trace", str(edge)]) == 2
    err = capsys.readouterr().err
    assert "--trace" in err and "recovery_rate = 1" in err and "Assumption 1" in err


def test_cli_analyze_trace_from_sequence_numbers_and_a_csv_column(files: Path, capsys) -> None:
    plant = str(files / "plant.json")
    assert cli_main(["analyze", plant, "--trace", str(files / "seq.txt"), "--trace-sequence", "--json"]) in (0, 1)
    out = json.loads(capsys.readouterr().out)
    assert out["fit"]["samples"] == 7 and out["fit"]["model"] in ("bernoulli", "gilbert_elliott")
    imu = _exact(1_500, 2_000)
    (files / "radio.csv").write_text("t,imu\n" + "".join(f"{i},{x}\n" for i, x in enumerate(imu.tolist())))
    assert cli_main(["analyze", plant, "--trace", str(files / "radio.csv"), "--trace-column", "imu", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["fit"]["samples"] == 2_000 and out["fit"]["parameters"] == {"arrival_probability": "3/4"}
    assert cli_main(["analyze", plant, "--trace-column", "imu"]) == 2
    assert "--trace-column needs --trace" in capsys.readouterr().err


def test_cli_loop_trace(files: Path, capsys) -> None:
    args = ["loop", str(ROOT / "examples/loop_scalar.json"), "--trace", str(files / "long.txt"), "--json"]
    assert cli_main(args) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["fit"]["link"] == "/channel" and out["fit"]["verdict"] == "stable"


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with ready_client(Settings(workers=1, time_budget_s=60)) as c:
        yield c


def test_http_fit_answers_a_string_and_a_list(client: TestClient) -> None:
    trace = "".join(map(str, _exact(60, 100).tolist()))
    r = client.post("/v1/fit", json={"arrivals": trace, "level": 0.95, "model": "bernoulli"})
    assert r.status_code == 200
    assert r.json() == kfio.fit(trace, model="bernoulli").to_dict()
    assert r.json()["parameters"] == {"arrival_probability": "3/5"}
    r = client.post("/v1/fit", json={"arrivals": [int(c) for c in trace], "model": "bernoulli"})
    assert r.status_code == 200 and r.json()["parameters"] == {"arrival_probability": "3/5"}


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ({"arrivals": ""}, "/arrivals"),
        ({"arrivals": "1111"}, "/arrivals"),
        ({"arrivals": "01x1"}, "/arrivals"),
        ({"arrivals": [0, 1, 3]}, "/arrivals/2"),
        ({"arrivals": "0110", "model": "markov", "order": 3}, "/arrivals"),
        ({"arrivals": "0110", "level": 2}, "/level"),
        ({"arrivals": "0110", "colour": 1}, "/colour"),
        ({"level": 0.9}, "/arrivals"),
    ],
)
def test_http_fit_bad_input_is_422_naming_the_field(client: TestClient, body, field) -> None:
    r = client.post("/v1/fit", json=body)
    assert r.status_code == 422
    assert r.json()["field"] == field


def test_http_analyze_with_a_trace_channel(client: TestClient) -> None:
    body = {**PLANT, "channel": {"model": "trace", "arrivals": "".join(map(str, _exact(12_000, 20_000).tolist()))}}
    r = client.post("/v1/analyze", json=body)
    assert r.status_code == 200
    out = r.json()
    assert out["verdict"] == "stable" and out["fit"]["verdict"] == "stable"
    assert out["fit"]["parameters"] == {"arrival_probability": "3/5"}
    body["channel"] = {"model": "trace", "arrivals": "1011" * 50}  # every loss followed by an arrival: q = 1
    r = client.post("/v1/analyze", json=body)
    assert r.status_code == 422 and r.json()["field"] == "/channel/arrivals"
    body["channel"] = {"model": "trace", "arrivals": "10a1"}
    r = client.post("/v1/analyze", json=body)
    assert r.status_code == 422 and r.json()["field"] == "/channel/arrivals"


def test_fit_as_a_job_and_analyze_job_with_a_trace(client: TestClient) -> None:
    trace = "".join(map(str, _exact(600, 1_000).tolist()))
    r = client.post("/v1/jobs/fit", json={"arrivals": trace})
    assert r.status_code == 202
    url = r.headers["Location"]
    deadline = time.monotonic() + 60
    while (doc := client.get(url).json())["status"] not in ("done", "failed"):
        assert time.monotonic() < deadline
        time.sleep(0.05)
    assert doc["status"] == "done"
    result = client.get(url + "/result")
    assert result.status_code == 200 and result.json() == kfio.fit(trace).to_dict()
    assert client.post("/v1/jobs/fit", json={"arrivals": "01a"}).json()["field"] == "/arrivals"
    r = client.post("/v1/jobs/analyze", json={**PLANT, "channel": {"model": "trace", "arrivals": trace}})
    assert r.status_code == 202
    r = client.post("/v1/jobs/analyze", json={**PLANT, "channel": {"model": "trace", "arrivals": "1x"}})
    assert r.status_code == 422 and r.json()["field"] == "/channel/arrivals"


def test_trace_region_plot(client: TestClient) -> None:
    body = {**PLANT, "channel": {"model": "trace", "arrivals": "".join(map(str, _exact(370, 1_000).tolist()))}}
    r = client.post("/v1/plots/trace-region", json=body)
    assert r.status_code == 200 and r.content.startswith(b"\x89PNG\r\n\x1a\n")
    bursty = "".join(map(str, simulate_chain((0.3, 0.95), 5_000, 2).tolist()))
    r = client.post("/v1/plots/trace-region", json={**PLANT, "channel": {"model": "trace", "arrivals": bursty}})
    assert r.status_code == 200 and r.content.startswith(b"\x89PNG")
    order2 = "".join(map(str, simulate_chain((0.2, 0.9, 0.5, 0.95), 20_000, 3).tolist()))
    r = client.post("/v1/plots/trace-region", json={**PLANT, "channel": {"model": "trace", "arrivals": order2}})
    assert r.status_code == 422 and r.json()["field"] == "/channel/arrivals" and "Markov" in r.json()["rule"]
    r = client.post("/v1/plots/trace-region", json=PLANT)
    assert r.status_code == 422 and r.json()["field"] == "/channel/model"


def test_folder_of_traces_with_a_plant(files: Path, capsys) -> None:
    folder = files / "logs"
    folder.mkdir()
    for name in ("long.txt", "near.txt", "bad.txt"):
        (folder / name).write_text((files / name).read_text())
    args = ["fit", str(folder), "--plant", str(files / "plant.json"), "--json"]
    assert cli_main(args) == 8  # one file failed: an error row, as a sweep's
    rows = {r["file"]: r for r in json.loads(capsys.readouterr().out)["traces"]}
    assert rows["bad.txt"]["error"]["field"].endswith("bad.txt line 3")
    assert rows["long.txt"]["verdict"] == "stable" and rows["long.txt"]["confidence"]["verdict"] == "stable"
    assert rows["near.txt"]["confidence"]["verdict"] == "undecided"
    assert rows["near.txt"]["confidence"]["samples_needed"] > 1_000
    (folder / "bad.txt").unlink()
    assert cli_main(["fit", str(folder)]) == 0
    text = capsys.readouterr().out
    assert "long.txt: 20000 packets, bernoulli (arrival_probability = 3/5)" in text
    assert cli_main(["fit", str(files / "long.txt"), "--plant", str(files / "plant.json")]) == 2
