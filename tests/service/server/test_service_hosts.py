"""Only trusted ``Host`` names are answered: 421 for the rest, against DNS rebinding."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

from kfio.service.app import create_app
from kfio.service.host_check import LOOPBACK_HOSTS
from kfio.service.settings import Settings


def client_for(trusted_hosts: str) -> TestClient:
    # no lifespan (no worker pool): /healthz and the host check need none
    return TestClient(create_app(Settings(workers=1, job_workers=1, trusted_hosts=trusted_hosts)))


def status_for(client: TestClient, host: str, path: str = "/healthz") -> int:
    return client.get(path, headers={"Host": host}).status_code


def test_the_default_is_the_loopback_names(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("KFIO_TRUSTED_HOSTS", raising=False)  # the tests' conftest adds "testserver"
    assert Settings().trusted_hosts == LOOPBACK_HOSTS
    client = client_for(Settings().trusted_hosts)
    for host in ("localhost", "LOCALHOST:8000", "127.0.0.1:8000", "127.0.0.1", "[::1]:8000", "[::1]"):
        assert status_for(client, host) == 200, host
    # names a rebinding page would send; "testserver" is trusted only because the tests say so
    for host in ("evil.example", "127.0.0.1.evil.example", "localhost.evil.example:8000", "testserver", "", "[::2]"):
        assert status_for(client, host) == 421, host


def test_an_untrusted_host_gets_a_problem_and_reaches_no_route() -> None:
    client = client_for(LOOPBACK_HOSTS)
    for method, path in (("GET", "/healthz"), ("POST", "/v1/analyze"), ("GET", "/"), ("GET", "/no/such/route")):
        r = client.request(method, path, headers={"Host": "rebind.evil.example"}, json={})
        assert r.status_code == 421, (method, path)
        assert r.headers["content-type"] == "application/problem+json"
        problem = r.json()
        assert problem["type"] == "urn:kfio:problem:misdirected-request" and "rebind.evil.example" in problem["detail"]


def test_wildcards() -> None:
    client = client_for("*.example.org, localhost")
    assert status_for(client, "api.example.org") == 200
    assert status_for(client, "a.b.example.org:443") == 200
    assert status_for(client, "example.org") == 421
    assert status_for(client, "evilexample.org") == 421
    assert status_for(client, "localhost") == 200
    anything = client_for("*")
    assert status_for(anything, "whatever.example") == status_for(anything, "") == 200


@pytest.mark.parametrize("value", ["", " , ", "x" * 5000])
def test_an_empty_or_huge_list_is_refused(value: str) -> None:
    with pytest.raises(ValueError):
        Settings(trusted_hosts=value)
