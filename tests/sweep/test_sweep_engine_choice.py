"""``engine="auto"``: a sweep runs where it is cheapest, and the rows do not depend on where.

The first points run in this process, timed; the estimated work left decides between this
process and the embedded cluster (``AUTO_SERIAL_WORK_S``).  Both branches are checked against
``engine="serial"`` row for row, the cluster branch with the cluster replaced by a recorder (a
real cluster is the Dask tests' business) so the hand-over point is visible.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from kfio.service.cli import main
from kfio.sweep import _engine as engine_module
from kfio.sweep import iter_sweep, load_sweep, run_sweep

SWEEP = {
    "command": "analyze",
    "base": {
        "system": {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]], "Q": [[1, 0], [0, 1]], "R": [[1]]},
        "channel": {"model": "bernoulli", "arrival_probability": 0.5},
    },
    "axes": [{"pointer": "/channel/arrival_probability", "name": "p", "from": "1/5", "to": "19/20", "num": 40}],
}


def fields(rows) -> dict[int, dict]:
    return {r.index: r.fields for r in rows}


def test_a_small_sweep_stays_in_process_with_the_same_rows() -> None:
    spec = load_sweep(json.dumps(SWEEP))
    info: dict = {}
    rows = list(iter_sweep(spec, info=info))
    assert info["engine"] == "serial" and info["engine_reason"].startswith("in process: ")
    assert sorted(r.index for r in rows) == list(range(40))  # every point once
    assert fields(rows) == fields(run_sweep(spec, engine="serial").rows)


def test_above_the_threshold_the_cluster_takes_the_points_left(monkeypatch: pytest.MonkeyPatch) -> None:
    spec = load_sweep(json.dumps(SWEEP))
    calls: list[int] = []

    def recorder(spec, text, deadline, scheduler, workers, chunk_size, progress, cancel, reuse, info, first=0):
        calls.append(first)
        info.update(engine="dask", workers=2, chunks=1)
        for i, f in engine_module.evaluate_chunk(text, range(first, spec.size), deadline, reuse):
            yield engine_module._row(spec, i, f)

    monkeypatch.setattr(engine_module, "_iter_dask", recorder)
    monkeypatch.setattr(engine_module, "AUTO_SERIAL_WORK_S", 0.0)
    info: dict = {}
    rows = list(iter_sweep(spec, info=info))
    assert len(calls) == 1 and 2 <= calls[0] <= engine_module.AUTO_PROBE_POINTS  # after the timed points
    assert info["engine"] == "dask" and info["engine_reason"].startswith("embedded cluster: ")
    assert f"{40 - calls[0]} points left" in info["engine_reason"]
    assert sorted(r.index for r in rows) == list(range(40))
    assert fields(rows) == fields(run_sweep(spec, engine="serial").rows)


def test_a_named_scheduler_is_always_used(monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[str | None] = []

    def recorder(spec, text, deadline, scheduler, *args, **kwargs):
        seen.append(scheduler)
        return iter(())

    monkeypatch.setattr(engine_module, "_iter_dask", recorder)
    list(iter_sweep(load_sweep(json.dumps(SWEEP)), scheduler="tcp://127.0.0.1:1"))
    assert seen == ["tcp://127.0.0.1:1"]


def test_the_summary_line_says_where_and_why(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "sweep.json"
    path.write_text(json.dumps(SWEEP))
    assert main(["sweep", str(path), "--quiet", "--no-progress"]) == 0
    err = capsys.readouterr().err
    line = next(x for x in err.splitlines() if x.startswith("kfio sweep: 40 points"))
    assert "engine serial" in line and "; in process: " in line and "at which the embedded cluster pays off" in line
