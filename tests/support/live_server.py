"""Helpers for tests and benchmarks of the HTTP service (loopback only).

:class:`LiveServer` runs ``kfio serve`` in a subprocess on a free port of
127.0.0.1 and always stops it; every wait is bounded.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, Sequence

import httpx

REPO = Path(__file__).resolve().parents[2]
OPENAPI_PATH = REPO / "openapi" / "openapi.json"


def free_port() -> int:
    """A TCP port that was free on 127.0.0.1 a moment ago."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def wait_until_ready(base_url: str, timeout: float = 180.0, proc: subprocess.Popen[bytes] | None = None) -> None:
    """Poll ``/readyz`` until it answers 200, at most ``timeout`` seconds.

    Raises
    ------
    RuntimeError
        The server exited, or was not ready in time.
    """
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc is not None and proc.poll() is not None:
            raise RuntimeError(f"server exited with code {proc.returncode}")
        try:
            if httpx.get(f"{base_url}/readyz", timeout=2).status_code == 200:
                return
        except httpx.TransportError:
            pass
        time.sleep(0.1)
    raise RuntimeError(f"server at {base_url} not ready within {timeout} s")


class LiveServer:
    """``kfio serve`` in a subprocess, as a context manager.

    Parameters
    ----------
    command:
        The command to run; ``--host 127.0.0.1 --port <free>`` is appended.
        Default: ``python -m kfio.service.cli serve`` from this checkout.
    env:
        Extra environment variables (``KFIO_TIME_BUDGET_S``, ...).
    workers:
        ``--workers``.

    Examples
    --------
    ::

        with LiveServer(workers=2) as server:
            httpx.get(server.url + "/healthz")
    """

    def __init__(
        self,
        command: Sequence[str] | None = None,
        env: dict[str, str] | None = None,
        workers: int | None = None,
        cwd: Path | None = None,
        ready_timeout: float = 180.0,
    ) -> None:
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        base = list(command) if command is not None else [sys.executable, "-m", "kfio.service.cli", "serve"]
        self.argv = [*base, "--host", "127.0.0.1", "--port", str(self.port)]
        if workers is not None:
            self.argv += ["--workers", str(workers)]
        self.env = {**os.environ, **(env or {})}
        self.own_data_dir: Path | None = None
        if "KFIO_DATA_DIR" not in self.env:  # a job database of its own, never the user's (removed on exit)
            import tempfile

            self.own_data_dir = Path(tempfile.mkdtemp(prefix="kfio-data-"))
            self.env["KFIO_DATA_DIR"] = str(self.own_data_dir)
        self.cwd = cwd or REPO
        self.ready_timeout = ready_timeout
        self.proc: subprocess.Popen[bytes] | None = None
        self.log_path: Path | None = None

    def __enter__(self) -> LiveServer:
        import tempfile

        fd, name = tempfile.mkstemp(prefix="kfio-serve-", suffix=".log")
        self.log_path = Path(name)
        self.proc = subprocess.Popen(self.argv, cwd=self.cwd, env=self.env, stdout=fd, stderr=subprocess.STDOUT)
        os.close(fd)
        try:
            wait_until_ready(self.url, self.ready_timeout, self.proc)
        except BaseException:
            self.stop()
            raise RuntimeError(f"server did not start:\n{self.log()}") from None
        return self

    def log(self) -> str:
        """What the server printed so far (last 4000 characters)."""
        return self.log_path.read_text(errors="replace")[-4000:] if self.log_path else ""

    def stop(self) -> None:
        """SIGTERM (graceful: the pool is killed by the app), SIGKILL after 10 s."""
        if self.proc is None or self.proc.poll() is not None:
            return
        self.proc.terminate()
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(timeout=10)

    def __exit__(self, *exc: Any) -> None:
        self.stop()
        if self.log_path is not None:
            self.log_path.unlink(missing_ok=True)
        if self.own_data_dir is not None:
            import shutil

            shutil.rmtree(self.own_data_dir, ignore_errors=True)


#: Endpoint that :func:`slow_request` bodies are meant for.
SLOW_PATH = "/v1/simulate"


def slow_request(time_budget_s: float | None = None, seed: int = 1) -> bytes:
    """A valid request (for :data:`SLOW_PATH`) that takes minutes and validates in milliseconds.

    Monte Carlo at the size limits: ``n = 40``, 2,500 trajectories of 400
    steps (``10^6`` trajectory-steps), every step a batch of 40 x 40 Riccati
    updates; more than 30 s on this project's machines, and it honours its
    budget between steps.  ``seed`` is the simulation seed, so that requests
    differ and share no cached answer.
    """
    n = 40
    eye = [[1 if i == j else 0 for j in range(n)] for i in range(n)]
    A = [["101/100" if i == j else ("1/10" if j == i + 1 else 0) for j in range(n)] for i in range(n)]
    options: dict[str, Any] = {"simulate": {"steps": 400, "trajectories": 2500, "seed": seed}}
    if time_budget_s is not None:
        options["time_budget_s"] = time_budget_s
    body: dict[str, Any] = {
        "system": {"A": A, "C": eye, "Q": eye, "R": eye},
        "channel": {"model": "bernoulli", "arrival_probability": 0.5},
        "options": options,
    }
    return json.dumps(body).encode()


def memory_request(time_budget_s: float | None = None, seed: int = 1) -> bytes:
    """A valid request that needs far more memory than its imports: Monte Carlo with the most covariances.

    ``n = 40`` with every state measured and 20,000 trajectories (near the cap of 2^25 floats)
    for 50 steps: the packed batch alone is 131 MB and one full batch 256 MB, beside a
    workspace of the same order. (:func:`slow_request`'s 2,500 trajectories fit in a few
    hundred MiB since the simulation keeps one full batch at a time.)
    """
    body = json.loads(slow_request(time_budget_s, seed))
    body["options"]["simulate"].update({"steps": 50, "trajectories": 20_000})
    return json.dumps(body).encode()


#: Headers of a JSON POST sent with ``content=`` (the service refuses other media types with 415).
JSON_HEADERS = {"Content-Type": "application/json"}
