"""Settings and flags are range-checked; ``kfio serve`` refuses bad ones and never serves a dead pool."""

from __future__ import annotations

import json
import signal
import threading
from pathlib import Path

import pytest
from pydantic import ValidationError

from kfio.service import exitcodes
from kfio.service.cli import main
from kfio.service.pool import WorkerPool
from kfio.service.settings import Settings
from kfio.service.watchdog import MAX_MEMORY_MB

HUGE = "9999999999999"


@pytest.fixture
def request_file(tmp_path: Path) -> Path:
    path = tmp_path / "r.json"
    body = {"system": {"A": [[2]], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": "1/2"}}
    path.write_text(json.dumps(body))
    return path


@pytest.mark.parametrize("command", ["analyze", "bounds", "simulate"])
def test_memory_flag_out_of_range_is_exit_2_naming_it(
    command: str, request_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main([command, str(request_file), "--memory-mb", HUGE]) == exitcodes.INVALID_INPUT
    err = capsys.readouterr().err
    assert "--memory-mb" in err and str(MAX_MEMORY_MB) in err and "Error" not in err


@pytest.mark.parametrize("value", [HUGE, "abc", "-1", "1e3"])
def test_memory_variable_out_of_range_is_exit_2_naming_it(
    value: str, request_file: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("KFIO_MEMORY_MB", value)
    assert main(["analyze", str(request_file)]) == exitcodes.INVALID_INPUT
    err = capsys.readouterr().err
    assert "KFIO_MEMORY_MB" in err and "whole number of MiB" in err


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("memory_mb", HUGE),
        ("max_queue", "10" * 20),
        ("max_digits", "5000"),  # past Python's 4300-digit limit of int parsing
        ("header_timeout_s", "nan"),
        ("body_timeout_s", "inf"),
        ("max_connections", "0"),
        ("cache_bytes", "1" + "0" * 30),
    ],
)
def test_settings_are_range_checked(name: str, value: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(f"KFIO_{name.upper()}", value)
    with pytest.raises(ValidationError) as info:
        Settings()
    assert info.value.errors()[0]["loc"] == (name,)


def test_serve_refuses_a_bad_setting_with_exit_2_naming_it(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("KFIO_MEMORY_MB", HUGE)
    assert main(["serve", "--port", "0"]) == exitcodes.INVALID_INPUT
    err = capsys.readouterr().err
    assert "KFIO_MEMORY_MB" in err and str(MAX_MEMORY_MB) in err
    monkeypatch.delenv("KFIO_MEMORY_MB")
    assert main(["serve", "--port", "0", "--workers", "1000"]) == exitcodes.INVALID_INPUT
    assert "--workers" in capsys.readouterr().err


def test_serve_stops_with_exit_6_when_its_pool_cannot_start(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    async def fail(self: WorkerPool) -> None:
        self._ready.set()
        raise RuntimeError("no worker could start")

    monkeypatch.setattr(WorkerPool, "start", fail)
    # without the check the server would serve 503 forever: a Ctrl-C after a minute stops it (exit 0, a failure)
    guard = threading.Timer(60.0, signal.raise_signal, (signal.SIGINT,))
    guard.start()
    try:
        code = main(["serve", "--host", "127.0.0.1", "--port", "0", "--log-level", "critical"])
    finally:
        guard.cancel()
    assert code == exitcodes.CANNOT_SERVE
    assert "no worker could start" in capsys.readouterr().err
