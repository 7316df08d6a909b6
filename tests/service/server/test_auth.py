"""Who may use the service: bearer tokens.

With ``KFIO_API_TOKEN`` (or ``KFIO_API_TOKEN_FILE``) set, every route but
``/healthz`` and the page's and docs' files answers 401 problem+json without
``Authorization: Bearer <token>``; a server bound beyond loopback with no token
generates one and prints it, unless ``KFIO_AUTH=none``.
"""

from __future__ import annotations

import hmac
import json
import logging
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from fastapi.testclient import TestClient
from pydantic import SecretStr

from kfio.service import auth, exitcodes
from kfio.service.app import create_app
from kfio.service.auth import SettingError, configured_tokens, is_loopback, startup_tokens
from kfio.service.cli import main
from kfio.service.settings import Settings

from support.live_server import OPENAPI_PATH, free_port

TOKEN = "tok-" + "a1B2c3D4e5F6g7H8i9J0"
OTHER = "second-client-token-0123456789"
BODY = {"system": {"A": [[2]], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": "1/2"}}
OPEN = ["/healthz", "/", "/static/app.js", "/static/app.css", "/docs", "/redoc", "/openapi.json"]
CLOSED = ["/readyz", "/v1/jobs/0123456789abcdef", "/schemas/request.json", "/no/such/path", "/healthz/x"]


def _bearer(token: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {token}"}


def _ready(client: TestClient, headers: dict[str, str]) -> TestClient:
    deadline = time.monotonic() + 60
    while client.get("/readyz", headers=headers).status_code != 200:
        assert time.monotonic() < deadline, "the worker pool did not start"
        time.sleep(0.05)
    return client


@pytest.fixture(scope="module")
def guarded(tmp_path_factory) -> Iterator[TestClient]:
    """A server whose tokens come from the environment: KFIO_API_TOKEN and a file with two more lines."""
    token_file = tmp_path_factory.mktemp("tokens") / "tokens"
    token_file.write_text(f"# one token per client\n\n  {OTHER}  \n{TOKEN}\n")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("KFIO_API_TOKEN", "third-token-from-the-variable")
        mp.setenv("KFIO_API_TOKEN_FILE", str(token_file))
        settings = Settings(workers=1, job_workers=1)
    with TestClient(create_app(settings)) as client:
        yield _ready(client, _bearer(TOKEN))


def test_analyze_without_a_token_is_401_with_a_problem(guarded: TestClient) -> None:
    r = guarded.post("/v1/analyze", json=BODY)
    assert r.status_code == 401
    assert r.headers["content-type"].startswith("application/problem+json")
    assert r.headers["www-authenticate"] == 'Bearer realm="kfio"'
    doc = r.json()
    assert doc["type"] == "urn:kfio:problem:unauthorized" and doc["status"] == 401 and "Bearer" in doc["detail"]
    assert TOKEN not in r.text and OTHER not in r.text


def test_analyze_with_the_token_is_200(guarded: TestClient) -> None:
    r = guarded.post("/v1/analyze", json=BODY, headers=_bearer(TOKEN))
    assert r.status_code == 200 and r.json()["verdict"] == "unstable"  # |a|^2 (1 - 1/2) = 2 > 1


@pytest.mark.parametrize("token", [TOKEN, OTHER, "third-token-from-the-variable"])
def test_every_configured_token_works(guarded: TestClient, token: str) -> None:
    assert guarded.post("/v1/analyze", json=BODY, headers=_bearer(token)).status_code == 200
    assert guarded.post("/v1/analyze", json=BODY, headers={"Authorization": f"bearer  {token}"}).status_code == 200


@pytest.mark.parametrize(
    "header",
    [
        f"Bearer {TOKEN}x",
        f"Bearer {TOKEN[:-1]}",
        "Bearer # one token per client",
        "Bearer ",
        f"Basic {TOKEN}",
        TOKEN,
        f"Bearer {TOKEN.upper()}",
    ],
)
def test_a_wrong_token_is_401(guarded: TestClient, header: str) -> None:
    r = guarded.post("/v1/analyze", json=BODY, headers={"Authorization": header})
    assert r.status_code == 401 and r.json()["status"] == 401
    assert TOKEN not in r.text and header.split()[-1] not in r.text


def test_a_presented_wrong_token_gets_invalid_token(guarded: TestClient) -> None:
    r = guarded.get("/readyz", headers=_bearer("not-a-token-of-this-server"))
    assert r.status_code == 401 and 'error="invalid_token"' in r.headers["www-authenticate"]


@pytest.mark.parametrize("path", OPEN)
def test_healthz_the_page_and_the_docs_need_no_token(guarded: TestClient, path: str) -> None:
    assert guarded.get(path).status_code == 200
    assert guarded.get(path, headers=_bearer("wrong-but-ignored-here")).status_code == 200


@pytest.mark.parametrize("path", CLOSED)
def test_every_other_path_needs_it(guarded: TestClient, path: str) -> None:
    assert guarded.get(path).status_code == 401
    assert guarded.get(path, headers=_bearer(TOKEN)).status_code != 401


def test_jobs_need_it_too(guarded: TestClient) -> None:
    assert guarded.post("/v1/jobs/analyze", json=BODY).status_code == 401
    r = guarded.post("/v1/jobs/analyze", json=BODY, headers=_bearer(TOKEN))
    assert r.status_code == 202
    assert guarded.get(r.headers["location"]).status_code == 401
    assert guarded.get(r.headers["location"], headers=_bearer(TOKEN)).status_code == 200


def test_every_token_is_compared_in_constant_time(guarded: TestClient, monkeypatch) -> None:
    calls: list[tuple[bytes, bytes]] = []
    compare = hmac.compare_digest

    def counting(a: bytes, b: bytes) -> bool:
        calls.append((a, b))
        return compare(a, b)

    monkeypatch.setattr(auth.hmac, "compare_digest", counting)
    guarded.get("/readyz", headers=_bearer(OTHER))
    assert len(calls) == 3  # each of the three tokens, though the first may have matched
    assert {b for _, b in calls} == {TOKEN.encode(), OTHER.encode(), b"third-token-from-the-variable"}


def test_tokens_are_never_logged(guarded: TestClient, caplog) -> None:
    with caplog.at_level(logging.DEBUG):
        guarded.post("/v1/analyze", json=BODY, headers=_bearer(TOKEN))
        guarded.post("/v1/analyze", json=BODY, headers=_bearer(TOKEN + "-wrong"))
        guarded.post("/v1/analyze", json=BODY)
    assert all(TOKEN not in record.getMessage() for record in caplog.records)


def test_without_tokens_the_loopback_server_is_open() -> None:
    app = create_app(Settings(workers=1, job_workers=1))
    with TestClient(app) as client:
        _ready(client, {})
        assert client.post("/v1/analyze", json=BODY).status_code == 200


@pytest.mark.parametrize(
    ("settings", "setting", "words"),
    [
        (Settings(api_token=SecretStr("short")), "KFIO_API_TOKEN", "at least 16"),
        (Settings(api_token=SecretStr("has a space in it, so no")), "KFIO_API_TOKEN", "no spaces"),
        (Settings(api_token_file="/nonexistent/tokens"), "KFIO_API_TOKEN_FILE", "cannot read"),
        (Settings(api_token=SecretStr(TOKEN), auth="none"), "KFIO_AUTH", "turns access control off"),
    ],
)
def test_unusable_token_settings_name_the_variable_never_the_token(settings, setting, words) -> None:
    with pytest.raises(SettingError) as err:
        configured_tokens(settings)
    assert err.value.setting == setting and words in err.value.rule
    secret = settings.api_token.get_secret_value() if settings.api_token else "\0"
    assert secret not in str(err.value)


def test_a_token_file_without_tokens_or_with_a_bad_line_is_refused(tmp_path: Path) -> None:
    empty = tmp_path / "empty"
    empty.write_text("# nothing yet\n\n")
    with pytest.raises(SettingError, match="holds no token"):
        configured_tokens(Settings(api_token_file=str(empty)))
    bad = tmp_path / "bad"
    bad.write_text(f"{TOKEN}\nshort\n")
    with pytest.raises(SettingError, match=r"line 2") as err:
        configured_tokens(Settings(api_token_file=str(bad)))
    assert "short" not in str(err.value).replace("at least", "")
    assert configured_tokens(Settings(api_token=SecretStr(""))) == ()  # an empty variable sets nothing


def test_a_server_beyond_loopback_without_a_token_generates_one() -> None:
    settings, message = startup_tokens(Settings(host="0.0.0.0"))
    assert message is not None and settings.api_token is not None
    token = settings.api_token.get_secret_value()
    assert len(token) >= 32 and f"Authorization: Bearer {token}" in message and "KFIO_AUTH=none" in message
    assert configured_tokens(settings) == (token,)
    again, _ = startup_tokens(Settings(host="0.0.0.0"))
    assert again.api_token is not None and again.api_token.get_secret_value() != token  # fresh per run


@pytest.mark.parametrize(
    "settings",
    [
        Settings(host="0.0.0.0", auth="none"),
        Settings(host="127.0.0.1"),
        Settings(host="::1"),
        Settings(host="localhost"),
        Settings(host="0.0.0.0", api_token=SecretStr(TOKEN)),
    ],
)
def test_no_token_is_generated_when_none_is_needed_or_one_is_set(settings: Settings) -> None:
    kept, message = startup_tokens(settings)
    assert message is None and kept == settings


def test_loopback_names() -> None:
    assert all(map(is_loopback, ["127.0.0.1", "127.5.5.5", "::1", "[::1]", "localhost", "LOCALHOST"]))
    assert not any(map(is_loopback, ["0.0.0.0", "::", "10.0.0.1", "kfio.example.org", "localhost.evil"]))


def test_serve_refuses_an_unusable_token_at_start(monkeypatch, capsys) -> None:
    monkeypatch.setenv("KFIO_API_TOKEN", "short")
    assert main(["serve", "--port", "0"]) == exitcodes.INVALID_INPUT
    err = capsys.readouterr().err
    assert err.startswith("kfio: invalid setting KFIO_API_TOKEN: ") and "'short'" not in err


def test_openapi_declares_the_bearer_scheme() -> None:
    for doc in (json.loads(OPENAPI_PATH.read_text()), create_app(Settings()).openapi()):
        scheme = doc["components"]["securitySchemes"]["bearerAuth"]
        assert scheme["type"] == "http" and scheme["scheme"] == "bearer"
        assert doc["paths"]["/healthz"]["get"]["security"] == []
        analyze = doc["paths"]["/v1/analyze"]["post"]
        assert {"bearerAuth": []} in analyze["security"] and "401" in analyze["responses"]
        closed = [op for path, item in doc["paths"].items() if path != "/healthz" for op in item.values()]
        assert closed and all({"bearerAuth": []} in op["security"] for op in closed)


@pytest.fixture(scope="module")
def beyond_loopback(tmp_path_factory) -> Iterator[tuple[str, str, Path]]:
    """``kfio serve --host 0.0.0.0`` with no token configured, as the container runs it: its URL, token and log."""
    port = free_port()
    env = {**os.environ, "KFIO_WORKERS": "1", "KFIO_JOB_WORKERS": "1", "KFIO_TRUSTED_HOSTS": "127.0.0.1"}
    for name in ("KFIO_API_TOKEN", "KFIO_API_TOKEN_FILE", "KFIO_AUTH"):
        env.pop(name, None)
    log = tmp_path_factory.mktemp("serve") / "serve.log"
    with open(log, "wb") as out:
        proc = subprocess.Popen(
            [sys.executable, "-m", "kfio.service.cli", "serve", "--host", "0.0.0.0", "--port", str(port)],
            stdout=out,
            stderr=subprocess.STDOUT,
            env=env,
        )
    try:
        base = f"http://127.0.0.1:{port}"
        deadline = time.monotonic() + 120
        token = None
        while time.monotonic() < deadline and token is None:
            assert proc.poll() is None, log.read_text()
            for line in log.read_text().splitlines():
                if "Authorization: Bearer " in line:
                    token = line.split("Authorization: Bearer ", 1)[1].strip()
            time.sleep(0.1)
        assert token, log.read_text()
        while time.monotonic() < deadline:
            try:
                if httpx.get(f"{base}/readyz", headers=_bearer(token), timeout=2).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            time.sleep(0.1)
        yield base, token, log
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


@pytest.mark.slow
def test_kfio_serve_on_all_addresses_prints_a_token_and_requires_it(beyond_loopback) -> None:
    base, token, log = beyond_loopback
    assert httpx.get(f"{base}/healthz", timeout=5).status_code == 200
    assert httpx.get(f"{base}/readyz", timeout=5).status_code == 401
    assert httpx.post(f"{base}/v1/analyze", json=BODY, timeout=30).status_code == 401
    assert httpx.post(f"{base}/v1/analyze", json=BODY, headers=_bearer(token), timeout=30).status_code == 200
    assert log.read_text().count(token) == 1  # printed once at start, never logged with a request


@pytest.mark.slow
def test_the_page_asks_for_the_token_once_and_keeps_it_for_the_tab(beyond_loopback) -> None:
    from playwright.sync_api import sync_playwright

    base, token, _ = beyond_loopback
    asked: list[str] = []
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path="/usr/bin/chromium", headless=True, args=["--no-sandbox"])
        try:
            page = browser.new_page()
            page.on("dialog", lambda d: (asked.append(d.message), d.accept(token)))
            page.goto(base + "/")  # the shell loads without a token
            page.wait_for_function("Number(document.querySelector('#field-list').dataset.version) >= 1")
            page.click("button[data-endpoint=analyze]")
            page.wait_for_selector("#verdict", timeout=60_000)
            assert len(asked) == 1 and "access token" in asked[0]
            assert page.evaluate("sessionStorage.getItem('kfio-api-token')") == token
            assert "Bearer $KFIO_API_TOKEN" in page.input_value("#curl-cmd") and token not in page.content()
            with page.expect_response(lambda r: r.url.endswith("/v1/analyze"), timeout=60_000) as again:
                page.click("button[data-endpoint=analyze]")  # the second run sends the kept token: no new prompt
            assert again.value.status == 200 and len(asked) == 1
        finally:
            browser.close()


@pytest.mark.parametrize("path", ["/static/%2e%2e/readyz", "/docs-assets/%2e%2e/readyz", "/static/..%2fv1/jobs/x"])
def test_an_open_prefix_does_not_open_a_route_behind_it(guarded: TestClient, path: str) -> None:
    r = guarded.get(path)
    assert r.status_code in (401, 404) and "pool" not in r.text  # never /readyz's counters


def test_an_untrusted_host_is_421_before_any_token_is_asked(guarded: TestClient) -> None:
    r = guarded.post("/v1/analyze", json=BODY, headers={"Host": "evil.example"})
    assert r.status_code == 421
