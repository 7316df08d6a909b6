"""Issue 22, item 11: a job is validated, sized and refused as its synchronous twin, at submit time.

Reproducer: ``POST /v1/jobs/simulate`` with 10,000 steps x 20,000
trajectories answered 202 and the job then failed with 422, while ``POST
/v1/simulate`` refused the same body at once.  Jobs have their own, larger
work cap (``KFIO_JOB_MAX_TRAJECTORY_STEPS``, 10^8), still checked at submit.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient

from kfio.service.api.schemas import REQUEST_EXAMPLES
from kfio.service.app import create_app
from kfio.service.settings import Settings

SEED_2X2 = REQUEST_EXAMPLES["seed002-2x2"]["value"]  # Sinopoli et al. (2004)'s 2x2 system
PROBLEM = "application/problem+json"
JSON = {"content-type": "application/json"}


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    settings = Settings(workers=1, job_workers=1, max_jobs=4, time_budget_s=30, job_max_trajectory_steps=3_000_000)
    with TestClient(create_app(settings)) as c:
        deadline = time.monotonic() + 60
        while c.get("/readyz").status_code != 200:
            assert time.monotonic() < deadline, "the worker pools did not start"
            time.sleep(0.05)
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
