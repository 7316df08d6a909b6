"""``kfio sweep``: table, plot, progress, exit codes, and an external Dask scheduler + worker pair."""

from __future__ import annotations

import csv
import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from kfio.service.cli import main

BASE = {
    "system": {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]], "Q": [[20, 0], [0, 20]], "R": [[2.5]]},
    "channel": {"model": "bernoulli", "arrival_probability": 0.5},
}
SWEEP = {
    "command": "analyze",
    "base": BASE,
    "axes": [{"pointer": "/channel/arrival_probability", "from": "3/10", "to": "9/10", "num": 13}],
}


def write(tmp_path: Path, doc) -> str:
    path = tmp_path / "sweep.json"
    path.write_text(json.dumps(doc))
    return str(path)


def test_serial_sweep_writes_table_plot_and_streams_rows(tmp_path, capsys):
    out, png = tmp_path / "t.csv", tmp_path / "p.png"
    code = main(["sweep", write(tmp_path, SWEEP), "--serial", "--out", str(out), "--plot", str(png), "--progress"])
    captured = capsys.readouterr()
    assert code == 0
    lines = [json.loads(x) for x in captured.out.splitlines()]
    assert sorted(x["index"] for x in lines) == list(range(13))
    rows = list(csv.DictReader(out.open()))
    assert [r["axis:/channel/arrival_probability"] for r in rows][:3] == ["3/10", "7/20", "2/5"]
    assert [r["verdict"] for r in rows][:2] == ["unstable", "unstable"] and rows[2]["verdict"] == "stable"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "13/13" in captured.err and "pt" in captured.err  # the progress bar (tqdm) with its counts
    assert "13 points, 0 with errors" in captured.err


def test_parquet_table(tmp_path, capsys):
    pq = pytest.importorskip("pyarrow.parquet", reason="the sweep extra (pyarrow) is part of the test install")
    out = tmp_path / "t.parquet"
    assert main(["sweep", write(tmp_path, SWEEP), "--serial", "--quiet", "--out", str(out)]) == 0
    table = pq.read_table(out)
    assert table.num_rows == 13 and "critical_arrival_probability_exact" in table.column_names
    assert set(table.column("critical_arrival_probability_exact").to_pylist()) == {"9/25"}


def test_bad_axis_exits_2_before_any_work(tmp_path, capsys):
    doc = {**SWEEP, "axes": [{"pointer": "/channel/arrival_probabilty", "values": [0.5]}]}
    assert main(["sweep", write(tmp_path, doc), "--serial"]) == 2
    err = capsys.readouterr().err
    assert "/axes/0/pointer" in err and "nothing at /channel/arrival_probabilty" in err


def test_bad_point_is_named_and_nothing_runs(tmp_path, capsys):
    doc = {**SWEEP, "axes": [{"pointer": "/system/Q/0/1", "values": [0, 3]}]}  # Q must be symmetric
    assert main(["sweep", write(tmp_path, doc), "--serial"]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and "/points/1/system/Q" in captured.err


def test_point_errors_exit_8(tmp_path, capsys):
    doc = {**SWEEP, "axes": [{"pointer": "/channel/arrival_probability", "values": ["1/2", "1"]}]}
    assert main(["sweep", write(tmp_path, doc), "--serial", "--quiet"]) == 8
    assert "2 points, 1 with errors" in capsys.readouterr().err


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _dask_cli() -> list[str]:
    """The ``dask`` command of this environment (its script, or ``python -m dask`` where a venv has none)."""
    script = Path(sys.executable).parent / "dask"
    return [str(script)] if script.exists() else [sys.executable, "-m", "dask"]


@pytest.mark.slow
def test_sweep_on_a_separately_started_scheduler_and_worker(tmp_path):
    """``dask scheduler`` + two ``dask worker`` processes on loopback, as docs/sweeps.md tells users to start them."""
    port = _free_port()
    addr = f"tcp://127.0.0.1:{port}"
    bindir = Path(sys.executable).parent
    env = {**os.environ, "DASK_DISTRIBUTED__WORKER__DAEMON": "False"}
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "env": env}
    sched = subprocess.Popen(
        [*_dask_cli(), "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"], **quiet
    )
    workers = [
        subprocess.Popen([*_dask_cli(), "worker", addr, "--nthreads", "1", "--no-dashboard"], **quiet) for _ in range(2)
    ]
    try:
        from distributed import Client

        deadline = time.monotonic() + 90
        while True:
            try:
                with Client(addr, timeout=5) as c:
                    c.wait_for_workers(2, timeout=max(1, deadline - time.monotonic()))
                break
            except (OSError, TimeoutError):
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.5)
        out = tmp_path / "t.csv"
        done = subprocess.run(
            [str(bindir / "kfio"), "sweep", write(tmp_path, SWEEP), "--scheduler", addr, "--quiet", "--out", str(out)],
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert done.returncode == 0, done.stderr[-2000:]
        assert "engine dask (2 workers" in done.stderr
        rows = list(csv.DictReader(out.open()))
        assert [int(r["index"]) for r in rows] == list(range(13))  # written in index order as the rows came
        serial = tmp_path / "serial.csv"
        assert main(["sweep", write(tmp_path, SWEEP), "--serial", "--quiet", "--out", str(serial)]) == 0
        assert out.read_text() == serial.read_text()  # the cluster's table is the serial one, byte for byte
        assert rows[-1]["verdict"] == "stable"
    finally:
        for p in (*workers, sched):
            p.terminate()
        for p in (*workers, sched):
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()


@pytest.mark.slow
def test_unreachable_scheduler_is_invalid_input(tmp_path, capsys):
    port = _free_port()
    assert main(["sweep", write(tmp_path, SWEEP), "--scheduler", f"tcp://127.0.0.1:{port}", "--quiet"]) == 2
    assert "cannot reach the Dask scheduler" in capsys.readouterr().err


def test_sweep_budget_gives_every_point_a_row_and_exit_4(tmp_path, capsys, monkeypatch):
    import types

    from kfio.sweep import _evaluate as evaluate

    # the workers' clock reads one hour later than the sweep's start: the budget is spent for every point
    monkeypatch.setattr(evaluate, "time", types.SimpleNamespace(time=lambda: time.time() + 3600))
    doc = {**SWEEP, "options": {"time_budget_s": "60", "chunk_size": 1}}
    out = tmp_path / "t.csv"
    assert main(["sweep", write(tmp_path, doc), "--serial", "--quiet", "--out", str(out)]) == 4
    rows = list(csv.DictReader(out.open()))
    assert [int(r["index"]) for r in rows] == list(range(13))
    assert all(r["error"].startswith("budget-exceeded") for r in rows)
