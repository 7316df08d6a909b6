"""Request factories shared by the test modules."""

from __future__ import annotations

import json

from kfio import load_request
from kfio.model._types import Request


def make(system: dict, channel: dict, simulate: dict | None = None) -> Request:
    """A validated request; ``simulate`` becomes ``options.simulate``."""
    body: dict = {"system": system, "channel": channel}
    if simulate is not None:
        body["options"] = {"simulate": simulate}
    return load_request(json.dumps(body))


def bern(lam) -> dict:
    return {"model": "bernoulli", "arrival_probability": lam}


def ge(p, q) -> dict:
    return {"model": "gilbert_elliott", "failure_rate": p, "recovery_rate": q}
