"""A ``bounds`` request solves the MARE once: ``P_hat_1`` is the covariance part's ``V_bar`` when the floats agree.

``P_hat_1 = V_bar`` (Rohr, Marelli and Fu (2010), Theorem 1).  The covariance bounds already solve
the MARE of Sinopoli et al. (2004) for the request's packet, so the ``P_hat`` sequence takes that
matrix instead of solving the same MARE again.  The report must be the same, bit for bit, as when
the sequence solves it itself.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from kfio import load_request
from kfio.riccati_bounds import _compute
from kfio.riccati_bounds._riccati import arrival_model, one_packet_model

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def report_json(text: str) -> str:
    return json.dumps(_compute.compute_bounds(load_request(text)).to_dict(), sort_keys=True, default=str)


@pytest.mark.parametrize("name", ["bounds_seed004_3x3.json", "bounds_seed004_scalar.json"])
def test_reused_v_bar_gives_the_same_report(name: str, monkeypatch) -> None:
    text = (EXAMPLES / name).read_text()
    calls = []
    real = _compute.p_hat_sequence

    def spy(*args, **kwargs):
        calls.append(kwargs.get("v_bar_known"))
        return real(*args, **kwargs)

    monkeypatch.setattr(_compute, "p_hat_sequence", spy)
    reused = report_json(text)
    assert calls and calls[-1] is not None  # the covariance part's V_bar was taken
    monkeypatch.setattr(_compute, "_same_model", lambda a, b: False)
    solved_again = report_json(text)
    assert calls[-1] is None
    assert reused == solved_again


def test_same_model_tells_different_floats_apart() -> None:
    A = np.array([[1.25, 1.0], [0.0, 0.9]])
    C = np.array([[1.0, 0.0], [0.0, 1.0]])
    Q, R = np.eye(2), np.eye(2)
    model = arrival_model(A, C, Q, R, [[0, 1]], [0.4])
    assert _compute._same_model(model, one_packet_model(A, C, Q, R, 0.4))
    assert not _compute._same_model(model, one_packet_model(A, C, Q, R, 0.5))
    assert not _compute._same_model(model, one_packet_model(A, C[::-1], Q, R, 0.4))  # rows in another order
    assert not _compute._same_model(model, one_packet_model(A, C[:1], Q, R[:1, :1], 0.4))
