"""An in-process app whose worker pools have started: the TestClient every HTTP test file needs."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager

from fastapi.testclient import TestClient

from kfio.service.app import create_app
from kfio.service.settings import Settings


@contextmanager
def ready_client(settings: Settings, timeout: float = 60.0) -> Iterator[TestClient]:
    """``TestClient(create_app(settings))`` once ``/readyz`` answers 200 (its pools are up), closed after use."""
    with TestClient(create_app(settings)) as c:
        deadline = time.monotonic() + timeout
        while c.get("/readyz").status_code != 200:
            assert time.monotonic() < deadline, "the worker pools did not start"
            time.sleep(0.05)
        yield c
