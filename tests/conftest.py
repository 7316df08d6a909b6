"""Shared test helpers."""

from __future__ import annotations

import json
import os
from typing import Any

import pytest

from kfio import load_request

# Starlette's TestClient sends "Host: testserver": the tests trust it beside the loopback names
# (a deployment trusts only these by default, kfio.service.host_check).
os.environ.setdefault("KFIO_TRUSTED_HOSTS", "localhost,127.0.0.1,[::1],testserver")


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
