"""Traces simulated from known channels (seeded NumPy), the oracle of the round trips."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import pytest

from support.traces import simulate_chain


@pytest.fixture
def simulate() -> Callable[[Sequence[float], int, int], np.ndarray]:
    return simulate_chain
