"""Reports from the Python API: frozen, readable, versioned, and the CLI's ``--json`` byte for byte."""

from __future__ import annotations

import dataclasses
import importlib.metadata
import json
import subprocess
import sys

import numpy as np
import pytest

import kfio

SYSTEM = kfio.System(A=np.array([[1.25, 0], [1, 1.1]]), C=[[1, 1]], Q=20 * np.eye(2), R=[[2.5]])


def cli_json(tmp_path, command: str, body: dict, *flags: str) -> str:
    path = tmp_path / f"{command}.json"
    path.write_text(json.dumps(body))
    p = subprocess.run(
        [sys.executable, "-m", "kfio.service.cli", command, str(path), "--json", *flags],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert p.returncode == 0, p.stderr
    return p.stdout


@pytest.mark.slow
def test_to_json_is_the_cli_output_byte_for_byte(tmp_path):
    ch = kfio.bernoulli(0.6)
    cases = [
        ("analyze", kfio.analyze(SYSTEM, ch), {}),
        ("bounds", kfio.bounds(SYSTEM, ch, options={"horizon": 2}), {"horizon": 2}),
        (
            "simulate",
            kfio.simulate(SYSTEM, ch, steps=20, trajectories=100, seed=3),
            {"steps": 20, "trajectories": 100, "seed": 3},
        ),
    ]
    for command, report, options in cases:
        body = kfio.request_dict(SYSTEM, ch, command=command, options=options or None)
        assert cli_json(tmp_path, command, body) == report.to_json() + "\n"
        assert json.loads(report.to_json()) == report.to_dict()


def test_every_report_carries_the_package_version():
    assert kfio.__version__ == importlib.metadata.version("kfio")
    ch = kfio.bernoulli(0.6)
    sysq = kfio.System(A=[[1.2]], C=[[1]], Q=[[1]], R=[[1]])
    reports = [
        kfio.analyze(SYSTEM, ch),
        kfio.simulate(sysq, ch, steps=5, trajectories=10, exact_steps=3),
        kfio.expected_covariance(sysq, ch, 3),
    ]
    for r in reports:
        d = r.to_dict()
        assert next(iter(d)) == "kfio_version" and d["kfio_version"] == kfio.__version__ == r.kfio_version


def test_reports_are_frozen_and_read_well():
    r = kfio.analyze(SYSTEM, kfio.bernoulli(0.5))
    with pytest.raises(dataclasses.FrozenInstanceError):
        r.verdict = "unstable"  # type: ignore[misc]
    assert repr(r).startswith("StabilityReport(verdict='stable', critical_arrival_probability=0.36, ")
    assert "BlockReport(eigenvalues=('5/4',), modulus=1.25, period=1, sigma=0.5, rate=0.78125" in repr(r)
    assert len(repr(r)) < 400
    s = kfio.simulate(kfio.System(A=[[0.5]], C=[[1]], Q=[[1]], R=[[1]]), kfio.bernoulli(0.5), steps=4, trajectories=10)
    assert repr(s).startswith(
        "SimulationReport(exact_verdict='stable', steps=4, trajectories=10, seed=0, final_mean_trace="
    )
    with pytest.raises(dataclasses.FrozenInstanceError):
        SYSTEM.A = ()  # type: ignore[misc]
    assert (
        repr(SYSTEM)
        == "System(A=[['5/4', '0'], ['1', '11/10']], C=[['1', '1']], Q=[['20', '0'], ['0', '20']], R=[['5/2']])"
    )
    two = kfio.System(A=np.eye(2), C=np.eye(2), sensors={"a": [0], "b": [1]})
    assert repr(two).endswith("sensors={'a': [0], 'b': [1]})") and two == kfio.System(
        **{**two.to_dict(), "sensors": {"a": [0], "b": [1]}}
    )
    assert hash(SYSTEM) == hash(kfio.System(A=SYSTEM.A, C=SYSTEM.C, Q=SYSTEM.Q, R=SYSTEM.R))


@pytest.mark.slow
def test_bounds_report_repr():
    b = kfio.bounds(kfio.System(A=[[-1.25]], C=[[1]], Q=[[1]], R=[[2.5]]), kfio.bernoulli(0.4))
    assert repr(b).startswith(
        "BoundsReport(exact_verdict='not computed (kfio.analyze)', verdict_by_bounds='stable', "
        "critical_intervals=((0.36, 0.36"
    )
