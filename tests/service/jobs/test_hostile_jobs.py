"""A job is validated, sized and refused as its synchronous twin, at submit time.

Reproducer: ``POST /v1/jobs/simulate`` with 10,000 steps x 20,000
trajectories answered 202 and the job then failed with 422, while ``POST
/v1/simulate`` refused the same body at once.  Jobs have their own, larger
work cap (``KFIO_JOB_MAX_TRAJECTORY_STEPS``, 10^8), still checked at submit.
"""

from __future__ import annotations

import json
import shutil
import time
from collections.abc import Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient

from kfio.service.api.schemas import REQUEST_EXAMPLES
from kfio.service.settings import Settings

from support.app_client import ready_client

SEED_2X2 = REQUEST_EXAMPLES["seed002-2x2"]["value"]  # Sinopoli et al. (2004)'s 2x2 system
PROBLEM = "application/problem+json"
JSON = {"content-type": "application/json"}


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    settings = Settings(workers=1, job_workers=1, max_jobs=4, time_budget_s=30, job_max_trajectory_steps=3_000_000)
    with ready_client(settings) as c:
        yield c


def simulation(steps: int, trajectories: int | None = None) -> dict[str, Any]:
    sim: dict[str, Any] = {"steps": steps}
    if trajectories is not None:
        sim["trajectories"] = trajectories
    return {**SEED_2X2, "options": {"simulate": sim}}


def test_a_simulation_job_past_the_jobs_cap_is_refused_at_submit_like_its_synchronous_twin(client):
    body = json.dumps(simulation(10_000, 20_000))
    sync = client.post("/v1/simulate", content=body, headers=JSON)
    job = client.post("/v1/jobs/simulate", content=body, headers=JSON)
    assert sync.status_code == 422 and job.status_code == 422, job.text
    assert job.headers["content-type"] == PROBLEM
    assert job.json()["field"] == sync.json()["field"] == "/options/simulate/trajectories"
    assert "3000000" in job.json()["detail"]  # the job lane's own cap, named
    assert client.get("/readyz").json()["jobs"]["queued"] == 0


def test_a_job_may_do_more_work_than_a_request_up_to_its_own_cap(client):
    body = json.dumps(simulation(400, 5000))  # 2 * 10^6 trajectory-steps: past a request's 10^6, within the job's
    assert client.post("/v1/simulate", content=body, headers=JSON).status_code == 422
    r = client.post("/v1/jobs/simulate", content=body, headers=JSON)
    assert r.status_code == 202, r.text
    location = r.headers["location"]
    deadline = time.monotonic() + 300
    while (doc := client.get(location).json())["status"] not in ("done", "failed", "cancelled"):
        assert time.monotonic() < deadline, doc
        time.sleep(0.1)
    assert doc["status"] == "done", doc
    assert doc["result"]["trajectories"] == 5000 and doc["result"]["steps"] == 400


def test_a_simulation_job_without_a_count_equals_its_synchronous_twin(client):
    body = json.dumps(simulation(50))
    r = client.post("/v1/jobs/simulate", content=body, headers=JSON)
    assert r.status_code == 202, r.text
    location = r.headers["location"]
    deadline = time.monotonic() + 120
    while (doc := client.get(location).json())["status"] not in ("done", "failed", "cancelled"):
        assert time.monotonic() < deadline, doc
        time.sleep(0.1)
    assert doc["status"] == "done", doc
    assert client.get(location + "/result").content == client.post("/v1/simulate", content=body, headers=JSON).content


def test_kept_results_are_bounded_by_bytes_the_first_finished_forgotten_first():
    """Finished results are evicted by bytes as well as by count (64 sweeps of 100,000 points would hold about 2 GiB)."""
    from kfio.service.jobstore import Job, JobStore

    store = JobStore(Settings(job_workers=1, job_retention=10, job_retention_bytes=2500))  # its lane is never started
    jobs = []
    for i, size in enumerate([1000, 1000, 1000, 400]):
        job = Job(f"j{i}", "analyze", b"", {}, 1.0, status="done", finished=100.0 + i, content=b"x" * size)
        jobs.append(job)
    running = Job("r", "sweep", b"{}", {}, 1.0, status="running")
    for job in [jobs[2], jobs[0], running, jobs[3], jobs[1]]:  # submission order differs from finishing order
        store._jobs[job.id] = job
    store._evict()
    # 3400 bytes held: j0 (finished first) goes, leaving 2400 <= 2500; the running job is never touched
    assert set(store._jobs) == {"j1", "j2", "j3", "r"}
    store._jobs["big"] = Job("big", "sweep", b"", {}, 1.0, status="done", finished=200.0, content=b"y" * 9999)
    store._evict()
    assert set(store._jobs) == {"big", "r"}  # the newest is kept whatever its size
    assert sum(len(j.content or b"") for j in store._jobs.values()) == 9999
    shutil.rmtree(store._dir)


def test_a_finished_job_past_the_byte_bound_makes_room_over_http():
    settings = Settings(workers=1, job_workers=1, max_jobs=4, time_budget_s=30, job_retention_bytes=1)
    with ready_client(settings) as c:
        locations = []
        for q in (20, 21):
            body = {**SEED_2X2, "system": {**SEED_2X2["system"], "Q": [[q, 0], [0, q]]}}
            r = c.post("/v1/jobs/analyze", content=json.dumps(body), headers=JSON)
            assert r.status_code == 202, r.text
            locations.append(r.headers["location"])
            deadline = time.monotonic() + 120
            while c.get(locations[-1]).json()["status"] not in ("done", "failed", "cancelled"):
                assert time.monotonic() < deadline
                time.sleep(0.05)
        assert c.get(locations[0]).status_code == 404  # forgotten when the second finished
        assert c.get(locations[1]).json()["status"] == "done"


def test_a_jobs_request_is_validated_in_a_worker_not_in_the_server(client, monkeypatch):
    """Exact validation grows with the matrices: it runs in the synchronous lane's worker, as for a request."""
    import kfio.service.jobs as server_side

    def forbidden(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("a job's request was validated in the server process")

    monkeypatch.setattr(server_side, "check_job_request", forbidden)
    bad = {**SEED_2X2, "system": {**SEED_2X2["system"], "Q": [[20, 0], [0, -20]]}}
    r = client.post("/v1/jobs/analyze", content=json.dumps(bad), headers=JSON)
    assert r.status_code == 422 and r.json()["field"] == "/system/Q", r.text
    r = client.post("/v1/jobs/simulate", content=json.dumps(simulation(10_000, 20_000)), headers=JSON)
    assert r.status_code == 422 and r.json()["field"] == "/options/simulate/trajectories", r.text
