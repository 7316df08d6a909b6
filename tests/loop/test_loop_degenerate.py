"""Degenerate loops: a link that changes nothing and ``rho(T) = 1`` exactly.

``A = [[1]], B = [[0]], C = [[0]]`` (any gains) and ``A = 1, B = 1, C = 0, L = 0``: the plant's state
is a random walk no packet touches, so ``T`` has the eigenvalue 1 whatever the links do.  The answer is
the verdict ``boundary`` (exit 3), no critical value (null, with a note naming why) in the report and in
the region plot, never a numerical failure.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import flint
import pytest
from fastapi.testclient import TestClient

from kfio.loop import analyze_loop, decide, loop_mjls, parse_loop_request
from kfio.loop._operator import operator_matrix
from kfio.loop._pencil import det_pencil, integer_pencil
from kfio.service.app import create_app
from kfio.service.cli import main as cli_main
from kfio.service.loop_plot import headline_text, loop_region_data, loop_region_figure
from kfio.service.settings import Settings


def _request(A: str, B: str, C: str, K: str, L: str) -> dict:
    return {
        "system": {"A": [[A]], "B": [[B]], "C": [[C]], "Q": [[1]], "R": [[1]]},
        "channel": {"model": "bernoulli", "arrival_probability": "0.8"},
        "actuator_channel": {"model": "bernoulli", "arrival_probability": "0.9"},
        "controller": {"gains": {"estimator": [[K]], "feedback": [[L]]}, "form": "predictor"},
    }


DEGENERATE = [
    pytest.param(_request("1", "0", "0", "0.5", "0.7"), id="B=0,C=0"),
    pytest.param(_request("1", "1", "0", "0.5", "0"), id="B=1,C=0,L=0"),
    pytest.param(_request("1", "0", "0", "0", "0"), id="all-gains-zero"),
]


@pytest.mark.parametrize("body", DEGENERATE)
def test_a_link_with_no_effect_gives_boundary_and_no_critical_value(body) -> None:
    req = parse_loop_request(body)
    # rho(T) = 1 exactly: I - T is singular (the plant's coordinate x is a random walk in every mode)
    T = operator_matrix(loop_mjls(req))
    eye = flint.fmpq_mat(T.nrows(), T.nrows())
    for i in range(T.nrows()):
        eye[i, i] = 1
    assert (eye - T).det() == 0
    report = analyze_loop(req).to_dict()
    assert report["verdict"] == "boundary" and report["cost"] is None
    assert report["critical_sensor_arrival_probability"] is None
    assert report["critical_actuator_arrival_probability"] is None
    assert len(report["critical_values"]) == 2
    for c in report["critical_values"]:
        assert c["value"] is None and c["value_exact"] is None
        assert "no effect" in c["note"]
        assert c["intervals"] == [{"from": 0.0, "to": 1.0, "verdict": "boundary"}]
    # the link really has no effect: the exact verdict is boundary at other arrival probabilities too
    for lam in ("0.1", "1"):
        other = dict(body, channel={"model": "bernoulli", "arrival_probability": lam})
        assert decide(loop_mjls(parse_loop_request(other))).verdict == "boundary"


@pytest.mark.slow
def test_the_cli_exits_3_and_http_answers_200_for_a_degenerate_loop(capsys, tmp_path: Path) -> None:
    body = DEGENERATE[0].values[0]
    path = tmp_path / "loop.json"
    path.write_text(json.dumps(body))
    assert cli_main(["loop", "--json", str(path)]) == 3
    out = json.loads(capsys.readouterr().out)
    assert out["verdict"] == "boundary" and out["critical_actuator_arrival_probability"] is None
    with TestClient(create_app(Settings(workers=1, job_workers=1, time_budget_s=60))) as client:
        deadline = time.monotonic() + 60
        while client.get("/readyz").status_code != 200:
            assert time.monotonic() < deadline
            time.sleep(0.05)
        r = client.post("/v1/loop", json=body)
        assert r.status_code == 200, r.text
        assert r.json()["verdict"] == "boundary"
        plot = client.post("/v1/plots/loop-region?points=3", json=body)
        assert plot.status_code == 200 and plot.headers["content-type"] == "image/png"


@pytest.mark.slow
def test_the_region_plot_says_boundary_and_names_the_missing_critical_values() -> None:
    req = parse_loop_request(DEGENERATE[1].values[0])
    data = loop_region_data(req, 3)
    assert all(v == "boundary" for row in data["labels"] for v in row)
    text = headline_text(data["report"], data["sensor"], data["actuator"])
    assert text.startswith("BOUNDARY") and text.count("none (the link has no effect)") == 2
    loop_region_figure(data)  # draws without error


def test_det_pencil_handles_a_pencil_the_parameter_does_not_enter() -> None:
    """``Q = 0`` (no column touched): no solve runs, so ``det(P) = 0 mod p`` is the singularity test.

    The branch ``det(P) = 0 mod p`` after a successful solve cannot happen: ``nmod_mat.solve`` raises
    for a matrix singular mod ``p``; checked here on a matrix singular mod a prime but not over Q.
    """
    P = flint.fmpz_mat([[1, 0], [0, 0]])
    Q = flint.fmpz_mat(2, 2)
    assert det_pencil(P, Q) is None  # singular over Q, the parameter absent: no polynomial
    P2 = flint.fmpz_mat([[2, 0], [0, 3]])
    assert det_pencil(P2, Q) == flint.fmpz_poly([6])  # constant det(P)
    p = 2305843009213693951  # 2^61 - 1, a prime below the 2^62 the primes are drawn from
    A = flint.nmod_mat([[p + 1, 1], [1, 1]], p)  # singular mod p: rows (1, 1), (1, 1)
    with pytest.raises(ZeroDivisionError):
        A.solve(flint.nmod_mat([[1], [0]], p))
    # an affine pencil through the rational route: T constant in x gives P singular at every base
    T0 = operator_matrix(loop_mjls(parse_loop_request(DEGENERATE[0].values[0])))
    P3, Q3 = integer_pencil(T0, T0 * 0)
    assert det_pencil(P3, Q3) is None
