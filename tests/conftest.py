"""Shared test helpers."""

from __future__ import annotations

import json
import os
import tempfile
from typing import Any

import pytest

from kfio import load_request

# Starlette's TestClient sends "Host: testserver": the tests trust it beside the loopback names
# (a deployment trusts only these by default, kfio.service.host_check).
os.environ.setdefault("KFIO_TRUSTED_HOSTS", "localhost,127.0.0.1,[::1],testserver")

# In-process commands (cli_main, kfio check workers) fork from this pytest worker, and RLIMIT_AS counts the
# address space the child inherits: a worker that has loaded Dask, browsers and BLAS threads maps most of
# the 3 GiB default, so the limit would fail C allocations at random under load.  The memory limit has its
# own tests, which set it explicitly (tests/service/cli/test_cli_watchdog.py, test_service_hardening.py).
os.environ.setdefault("KFIO_MEMORY_MB", "0")

# `kfio serve` keeps its jobs under $XDG_DATA_HOME/kfio unless KFIO_DATA_DIR says otherwise: one started
# by a test uses a directory of this run (of this xdist worker), never the user's (docs/service.md).
os.environ["XDG_DATA_HOME"] = tempfile.mkdtemp(prefix="kfio-tests-data-")


def make_request(A: Any, C: Any, channel: Any = None, **system: Any):
    """Build a validated request from Python values (numbers as strings stay exact)."""
    body = {
        "system": {"A": A, "C": C, **system},
        "channel": channel or {"model": "bernoulli", "arrival_probability": "1/2"},
    }
    return load_request(json.dumps(body))


@pytest.fixture
def req():
    return make_request
