"""Accepted jobs survive the process (SQLite under ``KFIO_DATA_DIR``).

Reproducer: after a SIGKILL and a restart, 11 accepted jobs (10 queued, 1
running) answered 404 ``unknown-job``.  Here a real ``kfio serve`` accepts four
loop jobs, is SIGKILLed while the first runs, starts again on the same data
directory, and all four finish; the running one ran a second time.
"""

from __future__ import annotations

import json
import shutil
import signal
import sqlite3
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from fastapi.testclient import TestClient

from kfio.service.jobdb import DB_NAME, MemoryRecords, SqliteRecords, StoreUnavailable, default_data_dir
from kfio.service.jobstore import MAX_RUNS, Job, JobStore
from kfio.service.settings import Settings

from support.app_client import ready_client
from support.live_server import JSON_HEADERS, LiveServer

FINISHED = {"done", "failed", "cancelled"}


def loop_request(n: int, arrival: str) -> dict[str, Any]:
    """An LQG loop of ``n`` states (``n = 4``: a few seconds in a worker); ``arrival`` tells requests apart."""
    eye = [[1 if i == j else 0 for j in range(n)] for i in range(n)]
    A = [["11/10" if i == j else ("1/10" if j == i + 1 else 0) for j in range(n)] for i in range(n)]
    bernoulli = {"model": "bernoulli", "arrival_probability": arrival}
    return {
        "system": {"A": A, "B": eye, "C": eye, "Q": eye, "R": eye},
        "channel": bernoulli,
        "actuator_channel": {"model": "bernoulli", "arrival_probability": 0.9},
        "controller": {"lqg": {"W": eye, "U": eye}},
        "cost": {"W": eye, "U": eye},
        "options": {"loop": {"protocol": "tcp", "on_loss": "zero"}},
    }


def poll(url: str, until: set[str], timeout: float = 240.0) -> dict[str, Any]:
    deadline = time.monotonic() + timeout
    while True:
        doc = httpx.get(url, timeout=10).json()
        if doc.get("status") in until:
            return doc
        assert time.monotonic() < deadline, doc
        time.sleep(0.1)


@pytest.mark.slow
def test_four_loop_jobs_all_finish_after_the_server_is_sigkilled_and_started_again(tmp_path: Path) -> None:
    env = {"KFIO_DATA_DIR": str(tmp_path / "data"), "KFIO_JOB_WORKERS": "1", "KFIO_LANE_WORKERS": "0"}
    ids = []
    with LiveServer(env=env, workers=1) as server:
        for k in range(4):
            r = httpx.post(
                f"{server.url}/v1/jobs/loop", content=json.dumps(loop_request(4, f"0.9{k}")), headers=JSON_HEADERS
            )
            assert r.status_code == 202, r.text
            doc = r.json()
            assert doc["retention_s"] == Settings().job_retention_s and doc["expires_at"] is None
            ids.append(doc["id"])
        poll(f"{server.url}/v1/jobs/{ids[0]}", {"running"})
        states = {i: httpx.get(f"{server.url}/v1/jobs/{i}").json()["status"] for i in ids}
        assert server.proc is not None
        server.proc.send_signal(signal.SIGKILL)
        server.proc.wait(timeout=30)
    assert states[ids[0]] == "running" and list(states.values()).count("queued") >= 2, states

    with LiveServer(env=env, workers=1) as server:
        for i in ids:  # every accepted id answers at once, before its job ran again
            assert httpx.get(f"{server.url}/v1/jobs/{i}").status_code == 200
        docs = [poll(f"{server.url}/v1/jobs/{i}", FINISHED) for i in ids]
        assert [d["status"] for d in docs] == ["done"] * 4, docs
        assert docs[0]["attempts"] == 2  # it was running when the server died: queued and run again
        for k, doc in enumerate(docs):
            assert doc["result"]["verdict"] == "stable"
            assert doc["expires_at"] is not None
            # the report is the synchronous endpoint's, byte for byte
            sync = httpx.post(
                f"{server.url}/v1/loop",
                content=json.dumps(loop_request(4, f"0.9{k}")),
                headers=JSON_HEADERS,
                timeout=60,
            )
            assert httpx.get(f"{server.url}/v1/jobs/{ids[k]}/result").content == sync.content
    with LiveServer(env=env, workers=1) as server:  # finished jobs answer after a graceful restart too
        assert httpx.get(f"{server.url}/v1/jobs/{ids[3]}").json()["status"] == "done"


def store(tmp_path: Path, **settings: Any) -> JobStore:
    return JobStore(Settings(job_workers=1, data_dir=str(tmp_path), **settings))  # its lane is never started


def stored_job(job_id: str, status: str, attempts: int) -> Job:
    return Job(job_id, "loop", b'{"x": 1}', {}, 10.0, status=status, attempts=attempts)


def test_a_job_found_running_is_queued_again_until_it_was_interrupted_max_runs_times(tmp_path: Path) -> None:
    records = SqliteRecords(tmp_path)
    for job in (stored_job("q", "queued", 0), stored_job("r1", "running", 1), stored_job("r2", "running", MAX_RUNS)):
        records.add(job.record())
    records.close()
    s = store(tmp_path)
    s._recover()
    assert s.get("q").status == "queued" and s.get("r1").status == "queued"
    assert s.get("r1").attempts == 1 and s.get("r1").body == b'{"x": 1}'  # runs again, with its request
    failed = s.get("r2")
    assert failed.status == "failed" and failed.problem is not None
    assert failed.problem.kind == "interrupted-by-restart" and str(MAX_RUNS) in failed.problem.detail
    assert s._queued == 2 and [s._queue.get_nowait().id for _ in range(2)] == ["q", "r1"]  # in the order accepted
    s.records.close()
    back = {r["id"]: r for r in SqliteRecords(tmp_path).load()}  # what the next start reads
    assert back["r1"]["status"] == "queued" and back["r2"]["status"] == "failed"
    assert back["r2"]["problem"]["kind"] == "interrupted-by-restart"


def test_a_graceful_close_leaves_queued_and_running_jobs_queued_without_counting_a_run(tmp_path: Path) -> None:
    import asyncio

    s = store(tmp_path)
    running = s.submit("loop", b'{"a": 1}')
    queued = s.submit("loop", b'{"b": 2}')
    running.status, running.attempts = "running", 1
    s._write(running, "status", "attempts")
    asyncio.run(s.close())
    back = {r["id"]: r for r in SqliteRecords(tmp_path).load()}
    assert back[running.id]["status"] == back[queued.id]["status"] == "queued"
    assert back[running.id]["attempts"] == 0 and back[running.id]["body"] == b'{"a": 1}'


def test_every_write_is_one_transaction(tmp_path: Path) -> None:
    records = SqliteRecords(tmp_path)
    statements: list[str] = []
    records._db.set_trace_callback(statements.append)
    records.add(stored_job("a", "queued", 0).record())
    records.update("a", status="done", content=b"{}", body=b"")
    records.remove(["a"])
    kinds = [s.split()[0].upper() for s in statements]
    assert kinds == ["BEGIN", "INSERT", "COMMIT", "BEGIN", "UPDATE", "COMMIT", "BEGIN", "DELETE", "COMMIT"], statements
    assert records._db.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    records.close()


class FullDisk:
    """A connection whose writes fail as SQLite's do on a full disk (reads still work)."""

    def __init__(self, db: sqlite3.Connection, fail_on: str) -> None:
        self.db, self.fail_on = db, fail_on

    def execute(self, sql: str, *args: Any) -> Any:
        if sql.startswith(self.fail_on):
            raise sqlite3.OperationalError("database or disk is full")
        return self.db.execute(sql, *args)

    def executemany(self, sql: str, rows: Any) -> Any:
        if sql.startswith(self.fail_on):
            raise sqlite3.OperationalError("database or disk is full")
        return self.db.executemany(sql, rows)

    @property
    def in_transaction(self) -> bool:
        return self.db.in_transaction

    def close(self) -> None:
        self.db.close()


@pytest.mark.parametrize("failing", ["UPDATE", "COMMIT"])
def test_a_write_that_fails_half_way_leaves_no_half_job(tmp_path: Path, failing: str) -> None:
    records = SqliteRecords(tmp_path)
    records.add(stored_job("a", "queued", 0).record())
    real = records._db
    records._db = FullDisk(real, failing)  # type: ignore[assignment]
    with pytest.raises(StoreUnavailable, match="disk is full"):
        records.update("a", status="done", content=b"x" * 1000, body=b"")
    records._db = real
    assert not real.in_transaction
    (back,) = records.load()
    assert back["status"] == "queued" and back["content"] is None and back["body"] == b'{"x": 1}'
    records.close()


@pytest.fixture
def durable_client(tmp_path: Path) -> Iterator[TestClient]:
    settings = Settings(workers=1, job_workers=1, lane_workers=0, max_jobs=4, data_dir=str(tmp_path))
    with ready_client(settings) as c:
        yield c


def test_a_full_disk_is_a_503_and_nothing_is_queued(durable_client: TestClient, tmp_path: Path) -> None:
    body = json.dumps(loop_request(1, "0.9"))
    records = durable_client.app.state.jobs.records  # type: ignore[attr-defined]
    real = records._db
    records._db = FullDisk(real, "INSERT")
    try:
        r = durable_client.post("/v1/jobs/loop", content=body, headers=JSON_HEADERS)
    finally:
        records._db = real
    assert r.status_code == 503 and r.headers["content-type"] == "application/problem+json", r.text
    assert r.json()["type"] == "urn:kfio:problem:store-unavailable" and "disk is full" in r.json()["detail"]
    assert "retry-after" in r.headers
    jobs = durable_client.get("/readyz").json()["jobs"]
    assert jobs["queued"] == jobs["running"] == 0 and records.load() == []
    r = durable_client.post("/v1/jobs/loop", content=body, headers=JSON_HEADERS)  # the disk has room again
    assert r.status_code == 202
    assert [rec["id"] for rec in records.load()] == [r.json()["id"]]


def test_a_second_server_on_the_same_data_directory_is_refused(tmp_path: Path) -> None:
    first = SqliteRecords(tmp_path)
    with pytest.raises(RuntimeError, match="KFIO_DATA_DIR.*another kfio server"):
        SqliteRecords(tmp_path)
    first.close()
    SqliteRecords(tmp_path).close()  # free again once the first has closed
    assert (tmp_path / DB_NAME).exists()


def test_finished_jobs_are_forgotten_when_their_retention_ends(tmp_path: Path) -> None:
    s = store(tmp_path, job_retention_s=100)
    now = time.time()
    for job_id, finished in (("old", now - 150), ("new", now - 50)):
        job = Job(job_id, "analyze", b"", {}, 1.0, status="done", finished=finished, content=b"{}", retention_s=100)
        s._jobs[job_id] = job
        s.records.add(job.record())
    s._evict()
    assert set(s._jobs) == {"new"} and [r["id"] for r in s.records.load()] == ["new"]
    s._jobs["new"].finished = now - 101  # the newest goes too once it expires
    s._evict()
    assert s._jobs == {} and s.records.load() == []
    s.records.close()


def test_without_a_data_dir_jobs_stay_in_memory_and_the_default_directory_is_the_xdg_one(monkeypatch) -> None:
    memory = JobStore(Settings())
    assert isinstance(memory.records, MemoryRecords)
    shutil.rmtree(memory._dir)
    monkeypatch.setenv("XDG_DATA_HOME", "/srv/data")
    assert default_data_dir() == Path("/srv/data/kfio")
    monkeypatch.delenv("XDG_DATA_HOME")
    assert default_data_dir() == Path.home() / ".local" / "share" / "kfio"


@pytest.mark.slow
def test_kfio_serve_on_a_data_directory_another_server_holds_exits_6_naming_the_setting(tmp_path: Path) -> None:
    import os
    import subprocess
    import sys

    held = SqliteRecords(tmp_path)
    try:
        env = {**os.environ, "KFIO_DATA_DIR": str(tmp_path)}
        done = subprocess.run(
            [sys.executable, "-m", "kfio.service.cli", "serve", "--port", "0"],
            env=env,
            capture_output=True,
            text=True,
            timeout=120,
        )
    finally:
        held.close()
    assert done.returncode == 6, done.stderr
    assert done.stderr.strip().splitlines() == [
        f"kfio: the data directory {tmp_path} (KFIO_DATA_DIR) is in use by another kfio server; "
        "give each server a directory of its own"
    ]
