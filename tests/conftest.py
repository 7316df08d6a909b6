"""Shared test helpers."""

from __future__ import annotations

import json
from typing import Any

import pytest

from kfio import load_request


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
