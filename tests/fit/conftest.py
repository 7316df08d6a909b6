"""Traces simulated from known channels (seeded NumPy), the oracle of the round trips."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import pytest

from support.traces import simulate_chain


@pytest.fixture
def simulate() -> Callable[[Sequence[float], int, int], np.ndarray]:
    return simulate_chain


@pytest.fixture(autouse=True)
def _no_inherited_memory_limit(monkeypatch: pytest.MonkeyPatch) -> None:
    """In-process ``kfio`` commands fork from this pytest worker, and RLIMIT_AS counts the address space
    the child inherits (a worker that has loaded Dask, browsers and BLAS threads maps most of the 3 GiB
    default): the memory limit is tested in tests/service/test_cli_watchdog.py, not here."""
    monkeypatch.setenv("KFIO_MEMORY_MB", "0")
