"""Jobs (``/v1/jobs``) in-process with real worker processes: lifecycle, cancel, crash, bounds, progress."""

from __future__ import annotations

import json
import os
import signal
import time
from collections.abc import Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient

from kfio.service.api.schemas import REQUEST_EXAMPLES
from kfio.service.jobstore import simulation_fraction
from kfio.service.settings import Settings

from support.app_client import ready_client
from support.live_server import slow_request

SEED_2X2 = REQUEST_EXAMPLES["seed002-2x2"]["value"]  # Sinopoli et al. (2004)'s 2x2 system: stable, lambda_c = 9/25
PROBLEM = "application/problem+json"


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    settings = Settings(workers=1, job_workers=1, max_jobs=1, job_retention=3, time_budget_s=30)
    with ready_client(settings) as c:
        yield c


def wait_for(client: TestClient, location: str, statuses: set[str], timeout: float = 120.0) -> dict[str, Any]:
    deadline = time.monotonic() + timeout
    while True:
        doc = client.get(location).json()
        if doc["status"] in statuses:
            return doc
        assert time.monotonic() < deadline, f"job stayed {doc['status']}"
        time.sleep(0.05)


def submit(client: TestClient, kind: str, body: bytes | dict[str, Any]) -> str:
    content = body if isinstance(body, bytes) else json.dumps(body).encode()
    r = client.post(f"/v1/jobs/{kind}", content=content, headers={"content-type": "application/json"})
    assert r.status_code == 202, r.text
    assert r.json()["status"] == "queued" and r.headers["location"] == f"/v1/jobs/{r.json()['id']}"
    return r.headers["location"]


def job_worker_pids(client: TestClient) -> set[int]:
    return {w.process.pid for w in client.app.state.jobs.pool._all}  # type: ignore[attr-defined]


def test_a_job_gives_the_synchronous_report_byte_for_byte(client: TestClient) -> None:
    location = submit(client, "analyze", SEED_2X2)
    doc = wait_for(client, location, {"done", "failed"})
    assert doc["status"] == "done", doc
    assert doc["kind"] == "analyze" and doc["started_at"] and doc["finished_at"] and "problem" not in doc
    sync = client.post("/v1/analyze", json=SEED_2X2)
    assert doc["result"] == sync.json()
    assert doc["result"]["critical_arrival_probability_exact"] == "9/25"
    result = client.get(location + "/result")
    assert result.status_code == 200 and result.content == sync.content
    # a finished job cannot be cancelled
    r = client.delete(location)
    assert r.status_code == 409 and r.headers["content-type"] == PROBLEM


def test_an_invalid_request_is_refused_before_it_is_queued(client: TestClient) -> None:
    bad = {**SEED_2X2, "system": {**SEED_2X2["system"], "Q": [[20, 0], [0, -20]]}}
    r = client.post("/v1/jobs/bounds", content=json.dumps(bad), headers={"content-type": "application/json"})
    assert r.status_code == 422 and r.headers["content-type"] == PROBLEM and r.json()["field"] == "/system/Q"


def test_an_option_only_the_computation_checks_fails_the_job_with_the_field_named(client: TestClient) -> None:
    bad = {**SEED_2X2, "options": {"bounds": {"horizon": 0}}}
    location = submit(client, "bounds", bad)
    doc = wait_for(client, location, {"done", "failed"})
    assert doc["status"] == "failed"
    assert doc["problem"]["status"] == 422 and doc["problem"]["field"] == "/options/bounds/horizon"
    r = client.get(location + "/result")  # the result of a failed job is its problem
    assert r.status_code == 422 and r.json()["field"] == "/options/bounds/horizon"


def test_a_body_that_is_not_json_is_refused_at_once(client: TestClient) -> None:
    r = client.post("/v1/jobs/analyze", content=b"{not json", headers={"content-type": "application/json"})
    assert r.status_code == 422 and r.headers["content-type"] == PROBLEM


def test_unknown_jobs_answer_404(client: TestClient) -> None:
    for r in (client.get("/v1/jobs/nope"), client.delete("/v1/jobs/nope"), client.get("/v1/jobs/nope/result")):
        assert r.status_code == 404 and r.json()["type"] == "urn:kfio:problem:unknown-job"


def test_cancel_kills_the_worker_and_the_lane_goes_on(client: TestClient) -> None:
    before = job_worker_pids(client)
    location = submit(client, "simulate", slow_request(seed=11))
    running = wait_for(client, location, {"running"})
    assert client.get(location + "/result").status_code == 409  # no result yet
    # the synchronous lane is not starved by the job
    sync = client.post("/v1/analyze", json=SEED_2X2)
    assert sync.status_code == 200 and sync.json()["verdict"] == "stable"
    r = client.delete(location)
    assert r.status_code == 200 and r.json()["status"] == "cancelled", r.text
    assert client.get(location).json()["status"] == "cancelled" and running["started_at"]
    # the worker that ran it was killed and replaced by a fresh process
    deadline = time.monotonic() + 60
    while not (job_worker_pids(client) and job_worker_pids(client).isdisjoint(before)):
        assert time.monotonic() < deadline, "the cancelled job's worker was not replaced"
        time.sleep(0.05)
    assert client.app.state.jobs.pool.replaced >= 1  # type: ignore[attr-defined]
    after = wait_for(client, submit(client, "analyze", SEED_2X2), {"done", "failed"})
    assert after["status"] == "done"


def test_a_worker_crash_fails_the_job_and_the_server_keeps_serving(client: TestClient) -> None:
    location = submit(client, "simulate", slow_request(seed=12))
    wait_for(client, location, {"running"})
    (pid,) = job_worker_pids(client)
    os.kill(pid, signal.SIGKILL)
    doc = wait_for(client, location, {"failed", "done", "cancelled"})
    assert doc["status"] == "failed"
    assert doc["problem"]["type"] == "urn:kfio:problem:worker-crashed", doc["problem"]
    assert "died" in doc["problem"]["detail"]
    assert client.get("/healthz").json() == {"status": "ok"}
    assert wait_for(client, submit(client, "analyze", SEED_2X2), {"done", "failed"})["status"] == "done"


def test_the_queue_is_bounded_with_429(client: TestClient) -> None:
    first = submit(client, "simulate", slow_request(seed=13))
    wait_for(client, first, {"running"})
    second = submit(client, "simulate", slow_request(seed=14))  # max_jobs = 1: this one waits
    assert client.get(second).json()["status"] == "queued"
    r = client.post("/v1/jobs/analyze", json=SEED_2X2)
    assert r.status_code == 429 and r.headers["content-type"] == PROBLEM and "retry-after" in r.headers
    assert r.json()["type"] == "urn:kfio:problem:too-many-jobs"
    # a queued job is cancelled without ever running
    assert client.delete(second).json()["status"] == "cancelled"
    assert client.get(second).json()["started_at"] is None
    assert client.delete(first).json()["status"] == "cancelled"


@pytest.mark.slow
def test_progress_and_budget_of_a_long_simulation(client: TestClient) -> None:
    location = submit(client, "simulate", slow_request(time_budget_s=4, seed=15))
    queued = client.get(location).json()
    assert queued["budget_s"] == 4.0  # the request asked for less than the deployment's hour
    seen: list[float] = []
    deadline = time.monotonic() + 120
    while (doc := client.get(location).json())["status"] in {"queued", "running"}:
        progress = doc["progress"] or {}
        if "fraction" in progress:
            assert progress["stage"] == "Monte Carlo simulation" and progress["steps"] > 0
            seen.append(progress["fraction"])
        assert time.monotonic() < deadline
        time.sleep(0.1)
    assert seen and 0 < seen[-1] < 1 and seen == sorted(seen)
    # 2,500 trajectories per step, 400 steps: the fraction is steps ticked over 10^6
    assert doc["status"] == "failed" and doc["problem"]["status"] == 504, doc


def test_finished_jobs_are_forgotten_past_the_retention(client: TestClient) -> None:
    locations = []
    for _ in range(4):  # job_retention = 3
        locations.append(submit(client, "analyze", SEED_2X2))
        assert wait_for(client, locations[-1], {"done", "failed"})["status"] == "done"
    submit(client, "analyze", SEED_2X2)
    assert client.get(locations[0]).status_code == 404
    assert client.get(locations[-1]).status_code == 200


def test_readyz_counts_jobs(client: TestClient) -> None:
    jobs = client.get("/readyz").json()["jobs"]
    assert jobs["workers"] == 1 and jobs["max_queued"] == 1
    assert set(jobs) >= {"queued", "running", "done", "failed", "cancelled"}


def test_simulation_fraction_counts_steps_over_the_horizon() -> None:
    options = {"simulate": {"steps": 400, "trajectories": 2500}}
    assert simulation_fraction(options, {"stage": "Monte Carlo simulation", "steps": 250_000, "last_n": 2500}) == 0.25
    assert simulation_fraction(None, {"stage": "Monte Carlo simulation", "steps": 100, "last_n": 1}) == 0.5  # 200 steps
    assert simulation_fraction(options, {"stage": "exact enumeration of E[P_t]", "steps": 5, "last_n": 1}) is None
