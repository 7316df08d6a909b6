"""Pieces of the HTTP service on their own: cache, problems, jobs, bounded body reads."""

from __future__ import annotations

import asyncio
import json
import os

import pytest

from kfio import AssumptionViolation, BudgetExceeded, InvalidInput, LimitExceeded, load_json
from kfio.service.cache import AnswerCache, CachedAnswer, canonical_json
from kfio.service.dispatch import read_body, requested_budget
from kfio.service.jobs import JOBS, run_job
from kfio.service.pool import PoolBusy, PoolTimeout, WorkerCrashed
from kfio.service.problems import Problem, ProblemError, problem_from_exception
from kfio.service.settings import Settings


def test_canonical_json_ignores_order_and_whitespace_keeps_number_text() -> None:
    a = canonical_json(load_json('{"b": [1.10, "1.1"], "a": {"y": 1, "x": null}}'))
    b = canonical_json(load_json('{ "a" : {"x":null,"y":1},\n "b":[1.10,"1.1"]}'))
    assert a == b == '{"a":{"x":null,"y":1},"b":[1.10,"1.1"]}'
    # a number is never the string that spells it
    assert canonical_json(load_json("[1.1]")) != canonical_json(load_json('["1.1"]'))


def test_lru_evicts_least_recently_used_by_entries_and_bytes() -> None:
    cache = AnswerCache(max_entries=2, max_bytes=1000)
    for k in "abc":
        cache.put(k, CachedAnswer(k.encode(), "application/json"))
        if k == "b":
            assert cache.get("a") is not None  # "a" is now the most recent
    assert cache.get("b") is None and cache.get("a") is not None and len(cache) == 2
    small = AnswerCache(max_entries=10, max_bytes=20)  # an entry costs key + content bytes (12 here)
    small.put("k1", CachedAnswer(b"x" * 10, "image/png"))
    small.put("k2", CachedAnswer(b"y" * 10, "image/png"))
    assert small.get("k1") is None and small.get("k2") is not None
    small.put("huge", CachedAnswer(b"z" * 100, "image/png"))  # larger than the cache: not kept
    assert small.get("huge") is None and small.get("k2") is not None
    assert AnswerCache(0, 100).get("x") is None


def test_lru_replacing_an_answer_counts_its_new_size_only() -> None:
    cache = AnswerCache(max_entries=10, max_bytes=30)  # each entry: 2 key bytes + its content
    cache.put("k1", CachedAnswer(b"x" * 8, "application/json"))
    cache.put("k2", CachedAnswer(b"y" * 8, "application/json"))
    cache.put("k1", CachedAnswer(b"z" * 12, "application/json"))  # 14 + 10 bytes fit: nothing evicted
    assert cache.get("k2") is not None and cache.get("k1").content == b"z" * 12
    assert cache.stats() == {"entries": 2, "bytes": 24, "hits": 2, "misses": 0}
    cache.put("k3", CachedAnswer(b"w" * 8, "application/json"))  # k2 (read before k1) is the least recent
    assert cache.get("k2") is None and cache.get("k1") is not None and cache.stats()["bytes"] == 24


@pytest.mark.parametrize(
    ("exc", "status", "kind"),
    [
        (InvalidInput("/system/A", "A must be square"), 422, "invalid-input"),
        (LimitExceeded("/system/A", "too big"), 422, "limit-exceeded"),
        (AssumptionViolation("/channel/arrival_probability", "0 < p < 1"), 422, "assumption-violation"),
        (BudgetExceeded("sigma: more than 1 s"), 504, "budget-exceeded"),
        (PoolTimeout("stopped"), 504, "budget-exceeded"),
        (PoolBusy("busy"), 503, "busy"),
        (WorkerCrashed("died"), 503, "worker-crashed"),
        (NotImplementedError(), 500, "internal"),
        (ZeroDivisionError("secret internals"), 500, "internal"),
    ],
)
def test_one_mapping_from_exceptions_to_problems(exc: Exception, status: int, kind: str) -> None:
    problem = problem_from_exception(exc)
    assert (problem.status, problem.kind) == (status, kind)
    doc = problem.to_dict()
    assert doc["type"] == f"urn:kfio:problem:{kind}" and doc["status"] == status
    if isinstance(exc, InvalidInput):
        assert (doc["field"], doc["rule"]) == (exc.field, exc.rule)
    if status == 500:
        assert "secret" not in doc["detail"]  # internals are logged, not sent
    assert Problem.from_dict(problem.as_plain()) == problem  # travels from workers as a dict


def test_run_job_never_raises() -> None:
    settings = Settings()
    assert run_job("analyze", b"{", settings, {}, 1.0)[0] == "problem"
    assert run_job("nope", b"{}", settings, {}, 1.0)[1]["status"] == 500  # an unknown job is a bug, logged
    status, fields = run_job("simulate", b'{"system": {"A": [[1]], "C": [[1]]}, "channel": {}}', settings, {}, 1.0)
    assert status == "problem" and fields["field"] == "/channel/model"
    assert set(JOBS) >= {"analyze", "bounds", "simulate", "plot-phase-transition", "plot-region", "plot-simulation"}


def test_requested_budget_is_read_leniently() -> None:
    assert requested_budget(load_json('{"options": {"time_budget_s": 2.5}}')) == 2.5
    assert requested_budget(load_json('{"options": {"time_budget_s": "1/4"}}')) == 0.25
    for text in ('{"options": {"time_budget_s": "soon"}}', '{"options": {"time_budget_s": -1}}', "[]", "{}"):
        assert requested_budget(load_json(text)) is None  # the worker reports invalid values


class _StreamingRequest:
    """Just enough of a Starlette request for :func:`read_body`."""

    def __init__(self, chunks: int, chunk_size: int, content_length: int | None = None) -> None:
        self.headers = {} if content_length is None else {"content-length": str(content_length)}
        self.chunks, self.chunk_size, self.consumed = chunks, chunk_size, 0

    async def stream(self):  # noqa: ANN201 - an async generator, like Starlette's
        for _ in range(self.chunks):
            self.consumed += 1
            yield b"x" * self.chunk_size


def test_read_body_stops_reading_past_the_limit() -> None:
    req = _StreamingRequest(chunks=1000, chunk_size=64 * 1024)  # 64 MiB, chunked (no Content-Length)
    with pytest.raises(ProblemError) as info:
        asyncio.run(read_body(req, 1 << 20))  # type: ignore[arg-type]
    assert info.value.problem.status == 413
    assert req.consumed == 17  # 16 chunks are exactly 1 MiB; the 17th passes the limit
    declared = _StreamingRequest(chunks=1000, chunk_size=64 * 1024, content_length=64 << 20)
    with pytest.raises(ProblemError):
        asyncio.run(read_body(declared, 1 << 20))  # type: ignore[arg-type]
    assert declared.consumed == 0  # refused on Content-Length alone
    ok = _StreamingRequest(chunks=2, chunk_size=10)
    assert asyncio.run(read_body(ok, 20)) == b"x" * 20  # type: ignore[arg-type]


def test_settings_read_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("KFIO_TIME_BUDGET_S", "7.5")
    monkeypatch.setenv("KFIO_WORKERS", "3")
    s = Settings()
    assert (s.time_budget_s, s.workers, s.limits().max_states) == (7.5, 3, 40)
    monkeypatch.setenv("KFIO_WORKERS", "0")
    with pytest.raises(ValueError, match="workers"):
        Settings()


def test_serve_refuses_invalid_settings(capsys: pytest.CaptureFixture[str]) -> None:
    from kfio.service.cli import main

    assert main(["serve", "--workers", "0"]) == 2
    assert "workers" in capsys.readouterr().err


def test_problem_bodies_are_json() -> None:
    body = Problem(503, "busy", "Service busy", "wait", retry_after=1).response()
    assert body.headers["retry-after"] == "1" and json.loads(body.body)["status"] == 503


@pytest.mark.parametrize("preset", [None, "3"])
def test_the_cli_runs_numpy_on_one_blas_thread_unless_told_otherwise(preset: str | None) -> None:
    # the thread variables must be set before NumPy loads its BLAS, i.e. before the command runs
    import subprocess
    import sys

    code = (
        "import os, sys\n"
        "from kfio.service import cli\n"
        "def run():\n"
        "    print(os.environ['OPENBLAS_NUM_THREADS'], os.environ['OMP_NUM_THREADS'], 'numpy' in sys.modules)\n"
        "    return 0, None\n"
        "cli.run = run\n"
        "cli.entrypoint()\n"
    )
    env = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    if preset is not None:
        env["OPENBLAS_NUM_THREADS"] = preset
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
    assert out.split() == [preset or "1", "1", "False"]
