"""A ``bounds`` request solves the MARE once: ``P_hat_1`` is the covariance part's ``V_bar``.

``P_hat_1 = V_bar`` (Rohr, Marelli and Fu (2010), Theorem 1).  The covariance bounds solve the
MARE of Sinopoli et al. (2004) for the request's packet; :func:`solve_v_bar` remembers that
answer for the same floats, so the ``P_hat`` sequence does not solve it again.  The report must be
the same, bit for bit, as when nothing is remembered.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from kfio import load_request
from kfio.riccati_bounds import _compute, _riccati
from kfio.riccati_bounds._riccati import arrival_model, one_packet_model

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


class Forgetful(dict):
    """A cache that keeps nothing: every :func:`solve_v_bar` call solves."""

    def __setitem__(self, key, value) -> None:
        pass


def report_json(text: str) -> str:
    return json.dumps(_compute.compute_bounds(load_request(text)).to_dict(), sort_keys=True, default=str)


@pytest.mark.parametrize("name", ["bounds_seed004_3x3.json", "bounds_seed004_scalar.json"])
def test_the_mare_is_solved_once_and_the_report_is_the_same(name: str, monkeypatch) -> None:
    text = (EXAMPLES / name).read_text()
    solved = []
    real = _riccati._solve_v_bar

    def spy(model, *args):
        solved.append(_riccati._model_key(model))
        return real(model, *args)

    monkeypatch.setattr(_riccati, "_solve_v_bar", spy)
    monkeypatch.setattr(_riccati, "_V_BAR_CACHE", {})
    remembered = report_json(text)
    assert solved and len(solved) == len(set(solved))  # no model solved twice in one request
    solved.clear()
    monkeypatch.setattr(_riccati, "_V_BAR_CACHE", Forgetful())
    solved_again = report_json(text)
    assert len(solved) > len(set(solved))  # the covariance part's MARE solved again for P_hat_1
    assert remembered == solved_again


def test_the_remembered_answer_tells_different_floats_apart() -> None:
    A = np.array([[1.25, 1.0], [0.0, 0.9]])
    C = np.array([[1.0, 0.0], [0.0, 1.0]])
    Q, R = np.eye(2), np.eye(2)
    key = _riccati._model_key(arrival_model(A, C, Q, R, [[0, 1]], [0.4]))
    assert key == _riccati._model_key(one_packet_model(A, C, Q, R, 0.4))
    assert key != _riccati._model_key(one_packet_model(A, C, Q, R, 0.5))
    assert key != _riccati._model_key(one_packet_model(A, C[::-1], Q, R, 0.4))  # rows in another order
    assert key != _riccati._model_key(one_packet_model(A, C[:1], Q, R[:1, :1], 0.4))
