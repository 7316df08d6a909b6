"""The stability LMI compiled once per shape: every instance gets the answers of a problem of its own.

:class:`kfio.riccati_bounds._lmi.StabilityLMI` (Sinopoli et al. (2004), Theorem 5(c)) shares one
compiled CVXPY problem per shape between instances, and keeps a Clarabel instance per
``StabilityLMI`` (``warm_start`` updates it between that instance's solves).  Solves of other
instances in between, or a problem compiled by an earlier request, must not change one bit.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from kfio import load_request
from kfio.riccati_bounds import _lmi
from kfio.riccati_bounds._compute import compute_bounds
from kfio.riccati_bounds._lmi import StabilityLMI

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
A = np.array([[1.25, 0.0], [1.0, 1.1]])
C = np.array([[1.0, 1.0]])
STEPS = [(0.5, 0.5), (0.45, 0.55), (0.4, 0.6), (0.42, 0.58)]


def same(a: _lmi.LMISolution, b: _lmi.LMISolution) -> bool:
    if (a.status, a.margin) != (b.status, b.margin) or (a.Y is None) != (b.Y is None):
        return False
    return a.Y is None or (np.array_equal(a.Y, b.Y) and all(np.array_equal(x, y) for x, y in zip(a.Z or (), b.Z or ())))


def test_interleaved_instances_get_the_answers_of_fresh_problems() -> None:
    _lmi._CACHE.clear()
    alone = StabilityLMI(2, (1,))
    want = [alone.solve(A, [C], w) for w in STEPS]
    _lmi._CACHE.clear()
    other = StabilityLMI(2, (1,))
    other.solve(2.0 * A, [C], (0.7, 0.3))  # compiles the shared problem with other data
    mine = StabilityLMI(2, (1,))
    assert mine._compiled is other._compiled
    got = []
    for w in STEPS:
        got.append(mine.solve(A, [C], w))
        other.solve(1.5 * A, [C], (0.3, 0.7))  # another instance's solve in between
    assert all(same(x, y) for x, y in zip(want, got))
    assert want[0].Y is not None  # the comparison is of answers, not of failures


def test_a_request_after_another_of_the_same_shape_is_unchanged() -> None:
    texts = [(EXAMPLES / name).read_text() for name in ("bounds_seed004_2x2.json", "bounds_differ_2x2.json")]

    def answer(text: str) -> str:
        return json.dumps(compute_bounds(load_request(text)).to_dict(), sort_keys=True, default=str)

    _lmi._CACHE.clear()
    first = answer(texts[0])
    assert _lmi._CACHE  # the request solved the LMI, so its problem is kept
    answer(texts[1])
    assert answer(texts[0]) == first


def test_cache_is_bounded() -> None:
    _lmi._CACHE.clear()
    for n in range(1, _lmi.CACHE_SIZE + 3):
        StabilityLMI(n, (1,))
    assert len(_lmi._CACHE) == _lmi.CACHE_SIZE


def test_large_problems_are_not_kept(monkeypatch) -> None:
    monkeypatch.setattr(_lmi, "CACHED_MAX_N", 2)
    _lmi._CACHE.clear()
    a, b = StabilityLMI(3, (1,)), StabilityLMI(3, (1,))
    assert a._compiled is not b._compiled and not _lmi._CACHE
