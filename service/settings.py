"""Deployment settings of the HTTP service (pydantic-settings, env prefix ``KFIO_``).

Nothing is read at import time: :func:`get_settings` builds the object on
first use and caches it, and :func:`kfio.service.app.create_app` takes a
:class:`Settings` explicitly so tests pass their own.

Examples
--------
>>> Settings(time_budget_s=5).time_budget_s
5.0
"""

from __future__ import annotations

import os
from functools import lru_cache
from typing import TYPE_CHECKING, Literal

from pydantic import Field, SecretStr
from pydantic_settings import BaseSettings, SettingsConfigDict

from kfio.model import MAX_RUN_BUDGET_S, Limits

if TYPE_CHECKING:
    from kfio.simulation import SimulationLimits

from .watchdog import DEFAULT_MEMORY_MB, MAX_MEMORY_MB

#: The names a local server answers for unless ``KFIO_TRUSTED_HOSTS`` says otherwise (:mod:`kfio.service.host_check`).
LOOPBACK_HOSTS = "localhost,127.0.0.1,[::1]"


def _default_workers() -> int:
    return max(1, min(4, os.cpu_count() or 1))


class Settings(BaseSettings):
    """Every knob of a deployment; each is also an environment variable ``KFIO_<NAME>``.

    Attributes
    ----------
    workers:
        Number of analysis worker *processes* (the event loop never computes).
    time_budget_s:
        Default and maximum wall-clock budget of one request; a request may
        ask for less with ``options.time_budget_s``.
    kill_grace_s:
        How long past its budget a worker may run (to raise ``BudgetExceeded``
        itself) before it is killed and replaced.
    memory_mb:
        Address-space limit (``RLIMIT_AS``, MiB) of each worker process once
        its imports are done (they take about 430 MiB); a request that needs
        more gets 422 ``memory-exceeded`` and its worker is replaced.  0: none.
    shutdown_grace_s:
        On SIGTERM, how long running requests may still finish; then they, and
        every request still waiting for a worker at once, get 503
        ``shutting-down`` with ``Retry-After``.
    max_queue:
        Requests allowed to wait for a free worker; beyond it the answer is
        503 at once.
    max_body_bytes:
        Largest accepted request body (413 beyond it).
    cache_entries, cache_bytes:
        Bounds of the in-memory LRU cache of answers.
    max_states, max_analyze_states, max_markov_order, max_digits, max_outputs, max_sensors:
        Request size limits (:class:`kfio.Limits`); ``max_analyze_states`` is the state limit
        of ``analyze`` requests, ``max_states`` that of every other command.
    job_workers:
        Worker processes of the job lane (``/v1/jobs/...``), separate from
        ``workers`` so that long jobs never starve synchronous requests.
    job_time_budget_s:
        Default and maximum budget of one job (an hour by default); a job
        may ask for less with ``options.time_budget_s``.
    max_jobs:
        Jobs allowed to wait for a job worker; beyond it ``POST /v1/jobs/...``
        answers 429.
    job_retention:
        Finished jobs kept for polling (the oldest are forgotten first).
    job_retention_bytes:
        Bytes the kept jobs' results may hold (the first finished are forgotten
        first; the newest is kept whatever its size).
    dask_scheduler:
        Address of a Dask scheduler (``tcp://HOST:PORT``) that ``POST /v1/sweeps``
        runs its sweeps on; without it a sweep runs in its job-lane worker.
    max_sweep_points:
        Points one ``POST /v1/sweeps`` may have.
    job_max_trajectory_steps:
        Cap on a simulation job's ``steps * trajectories`` (a synchronous
        request has :class:`kfio.SimulationLimits`' 10^6: a job may run an hour).
    header_timeout_s, body_timeout_s:
        A request's headers must arrive within ``header_timeout_s`` of the
        connection opening (or of the request's first byte on a kept-alive
        connection), its body within ``body_timeout_s`` of its headers; the
        connection is closed otherwise (:mod:`kfio.service.connection_guard`).
    keep_alive_s:
        How long an idle kept-alive connection stays open.
    max_connections:
        Open connections at most (lowered to fit the descriptor limit); past
        it a new connection displaces the oldest one still owing its headers,
        or is answered 503.
    trusted_hosts:
        Comma-separated host names the server answers for (``*.example.org``
        for subdomains, ``*`` for any); any other ``Host`` is answered 421
        (:mod:`kfio.service.host_check`, against DNS rebinding).
    data_dir:
        Directory of the job database (:mod:`kfio.service.jobdb`); ``None``
        keeps jobs in memory only.  ``kfio serve`` sets it to
        :func:`kfio.service.jobdb.default_data_dir` when it is not given.
    job_retention_s:
        How long a finished job's result is kept (``job_retention`` and
        ``job_retention_bytes`` may forget the oldest sooner).
    lane_workers:
        Worker processes of the cheap lane (:mod:`kfio.service.lanes`): small
        requests run there when every worker of ``workers`` is busy; 0: no lane.
    lane_budget_s:
        Longest a request may run in the cheap lane; past it, it is moved to
        the main pool with what is left of its budget.
    send_timeout_s:
        A response whose client reads nothing for this long is cut off
        (:mod:`kfio.service.connection_guard`).
    api_token, api_token_file:
        Bearer tokens (:mod:`kfio.service.auth`): ``KFIO_API_TOKEN`` one token,
        ``KFIO_API_TOKEN_FILE`` a file with one token per line (several
        clients).  With any, every route but ``/healthz`` and the page's and
        docs' files answers 401 without ``Authorization: Bearer <token>``.
    auth:
        ``auto``: tokens when configured, and a generated one when ``kfio serve``
        binds beyond loopback without any; ``none``: no access control (a
        reverse proxy in front authenticates).
    """

    model_config = SettingsConfigDict(env_prefix="KFIO_", frozen=True, extra="ignore", allow_inf_nan=False)

    host: str = "127.0.0.1"
    port: int = Field(8000, ge=0, le=65535)
    workers: int = Field(default_factory=_default_workers, ge=1, le=64)
    time_budget_s: float = Field(30.0, gt=0, le=3600)
    kill_grace_s: float = Field(0.25, ge=0, le=60)
    memory_mb: int = Field(DEFAULT_MEMORY_MB, ge=0, le=MAX_MEMORY_MB)
    shutdown_grace_s: float = Field(3.0, ge=0, le=600)
    max_queue: int = Field(64, ge=0, le=100_000)
    max_body_bytes: int = Field(1 << 20, ge=1, le=1 << 30)
    cache_entries: int = Field(512, ge=0, le=10_000_000)
    cache_bytes: int = Field(64 << 20, ge=0, le=1 << 40)
    max_states: int = Field(Limits.max_states, ge=1, le=400)
    max_analyze_states: int = Field(Limits.max_analyze_states, ge=1, le=400)
    max_markov_order: int = Field(Limits.max_markov_order, ge=0, le=100)
    max_digits: int = Field(Limits.max_digits, ge=1, le=4000)  # below Python's 4300-digit int parsing limit
    max_outputs: int = Field(Limits.max_outputs, ge=1, le=400)
    max_sensors: int = Field(Limits.max_sensors, ge=1, le=64)
    job_workers: int = Field(1, ge=1, le=64)
    job_time_budget_s: float = Field(3600.0, gt=0, le=MAX_RUN_BUDGET_S)
    max_jobs: int = Field(16, ge=0, le=100_000)
    job_retention: int = Field(64, ge=1, le=100_000)
    job_retention_bytes: int = Field(256 << 20, ge=0, le=1 << 40)
    dask_scheduler: str | None = Field(None, pattern=r"^(tcp|tls|inproc)://[^\s]+$")
    max_sweep_points: int = Field(100_000, ge=1, le=1_000_000)
    job_max_trajectory_steps: int = Field(100_000_000, ge=1, le=10_000_000_000)
    header_timeout_s: float = Field(10.0, gt=0, le=600)
    body_timeout_s: float = Field(60.0, gt=0, le=3600)
    keep_alive_s: float = Field(5.0, gt=0, le=600)
    max_connections: int = Field(1000, ge=1, le=100_000)
    trusted_hosts: str = Field(LOOPBACK_HOSTS, max_length=4096, pattern=r"[^\s,]")  # at least one name
    # durable jobs, the cheap lane and slow readers (docs/service.md)
    data_dir: str | None = Field(None, min_length=1, max_length=4096)
    job_retention_s: float = Field(7 * 86400.0, gt=0, le=366 * 86400)
    lane_workers: int = Field(1, ge=0, le=16)
    lane_budget_s: float = Field(2.0, gt=0, le=60)
    send_timeout_s: float = Field(30.0, gt=0, le=3600)
    # Access control (kfio.service.auth), kept together here.
    api_token: SecretStr | None = None
    api_token_file: str | None = Field(None, max_length=4096)
    auth: Literal["auto", "none"] = "auto"

    def memory_bytes(self) -> int | None:
        """:attr:`memory_mb` in bytes, ``None`` for no limit."""
        return self.memory_mb << 20 if self.memory_mb else None

    def job_simulation_limits(self) -> SimulationLimits:
        """The simulation limits of a job: :attr:`job_max_trajectory_steps` work, the rest as a request's."""
        from dataclasses import replace

        from kfio.simulation import DEFAULT_SIMULATION_LIMITS

        return replace(DEFAULT_SIMULATION_LIMITS, max_trajectory_steps=self.job_max_trajectory_steps)

    def limits(self, command: str | None = None) -> Limits:
        """The request size limits of this deployment for ``command`` (:meth:`kfio.Limits.for_command`)."""
        return Limits(
            max_states=self.max_states,
            max_analyze_states=self.max_analyze_states,
            max_markov_order=self.max_markov_order,
            max_digits=self.max_digits,
            max_outputs=self.max_outputs,
            max_sensors=self.max_sensors,
        ).for_command(command)


@lru_cache(maxsize=1)
def get_settings() -> Settings:
    """The settings of this process, read from the environment once.

    Tests build their own :class:`Settings` and pass it to
    :func:`kfio.service.app.create_app`, or call ``get_settings.cache_clear()``.
    """
    return Settings()
