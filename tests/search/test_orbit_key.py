"""Shift-orbit keys by integer bit rotation agree with the sorted-tuple definition."""

from __future__ import annotations

import numpy as np
import pytest

from kfio.search._blind import SlotSpace


@pytest.mark.parametrize("phases,groups", [(1, 1), (7, 1), (15, 2), (36, 2), (60, 3), (9, 4)])
def test_orbit_key_matches_reference(phases, groups):
    rng = np.random.default_rng(phases * 10 + groups)
    space = SlotSpace(n_phases=phases, n_groups=groups, rows=np.zeros((phases * groups, 1, 1)), tol=1e-9)
    for density in (0.0, 0.2, 0.5, 0.9, 1.0):
        for _ in range(40):
            mask = rng.random(space.size) < density
            key = space.orbit_key(mask)
            assert key == space.orbit_key_reference(mask)
            # every rotation of the set has the same key
            k = int(rng.integers(phases))
            assert space.orbit_key(space.rotate(mask, k)) == key
