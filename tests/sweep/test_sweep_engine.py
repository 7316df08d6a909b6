"""Sweeps give exactly the rows of point-by-point analyses, serially and on a real Dask cluster."""

from __future__ import annotations

import json
import os
import signal
import threading

import pytest

from kfio import analyze, load_request
from kfio.riccati_bounds import compute_bounds
from kfio.sweep import cache_stats, clear_caches, iter_sweep, load_sweep, point_at, row_from_report, run_sweep
from kfio.sweep._spec import request_text

from support.plants import block_diagonal, cyclotomic_companion

SEED_2X2 = {
    "system": {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]], "Q": [[20, 0], [0, 20]], "R": [[2.5]]},
    "channel": {"model": "bernoulli", "arrival_probability": 0.5},
}
GE = {
    "system": {"A": [[2, 0], [0, -2]], "C": [[1, 1]]},
    "channel": {"model": "gilbert_elliott", "failure_rate": "1/10", "recovery_rate": "3/10"},
}


# 2 blkdiag(rotation of order 3, rotation of order 4, companion of Phi_5): one FMO class of period 60,
# an analysis slow enough (blind-set search) that a killed worker has work in flight
_A60 = block_diagonal(
    [[-1, -3], [1, -1]], [[0, -2], [2, 0]], cyclotomic_companion(5)
)  # cyclotomic_companion(5) is 2 companion(Phi_5)
PERIOD_60 = {
    "system": {"A": _A60, "C": [[1, 0, 1, 0, 1, 0, 0, 0]]},
    "channel": {"model": "bernoulli", "arrival_probability": 0.5},
}


def channel_sweep(num=25, **extra):
    return load_sweep(
        json.dumps(
            {
                "command": "analyze",
                "base": SEED_2X2,
                "axes": [{"pointer": "/channel/arrival_probability", "from": "1/5", "to": "19/20", "num": num}],
                **extra,
            }
        )
    )


def one_by_one(spec):
    """The independent route: each point's request text through load_request and analyze/bounds."""
    out = []
    for i in range(spec.size):
        req = load_request(request_text(point_at(spec, i).request))
        fn = {"analyze": analyze, "bounds": compute_bounds}[spec.command]
        out.append(row_from_report(spec.command, fn(req).to_dict()) | {"error": None})
    return out


def fields(result):
    return [{k: v for k, v in r.fields.items()} | {"error": r.fields.get("error")} for r in result.rows]


def test_serial_sweep_equals_point_by_point_and_reuses_the_structure():
    spec = channel_sweep()
    clear_caches()
    result = run_sweep(spec, engine="serial")
    assert [r.index for r in result.rows] == list(range(spec.size))
    assert fields(result) == one_by_one(spec)
    stats = cache_stats()
    assert stats["structure_misses"] == 1 and stats["structure_hits"] == spec.size - 1
    # the critical probability 9/25 (Sinopoli et al. 2004's 2x2 example) splits the verdicts
    verdicts = [r.fields["verdict"] for r in result.rows]
    assert verdicts[:6] == ["unstable"] * 6 and set(verdicts[6:]) == {"stable"}


def test_reuse_off_gives_the_same_rows():
    spec = channel_sweep(num=7)
    assert fields(run_sweep(spec, engine="serial", reuse=False)) == fields(run_sweep(spec, engine="serial"))


def test_noise_only_sweep_computes_the_verdict_once():
    spec = load_sweep(
        json.dumps(
            {
                "command": "analyze",
                "base": SEED_2X2,
                "axes": [{"pointer": "/system/R/0/0", "values": ["1/2", "1", "5/2", "10"]}],
            }
        )
    )
    clear_caches()
    result = run_sweep(spec, engine="serial")
    assert cache_stats()["verdict_misses"] == 1 and cache_stats()["verdict_hits"] == 3
    assert fields(result) == one_by_one(spec)


def test_bounds_sweep_rows_match_single_requests():
    spec = load_sweep(
        json.dumps(
            {
                "command": "bounds",
                "base": SEED_2X2,
                "axes": [{"pointer": "/channel/arrival_probability", "values": ["1/2", "7/10"]}],
            }
        )
    )
    got = fields(run_sweep(spec, engine="serial"))
    want = one_by_one(spec)
    for g, w in zip(got, want):
        assert g["verdict_by_bounds"] == w["verdict_by_bounds"]
        assert g["lambda_lower"] == w["lambda_lower"]
        # bisection and SDP are deterministic for the same input
        assert g["lambda_upper"] == w["lambda_upper"] and g["trace_V_bar"] == w["trace_V_bar"]


def test_failing_points_get_error_rows_and_the_sweep_goes_on():
    # arrival probability 1 breaks Assumption 1 (Rohr, Marelli and Fu 2014): no verdict, an error row
    spec = load_sweep(
        json.dumps(
            {
                "command": "analyze",
                "base": SEED_2X2,
                "axes": [{"pointer": "/channel/arrival_probability", "values": ["1/2", "1", "9/10"]}],
            }
        )
    )
    rows = run_sweep(spec, engine="serial").rows
    assert rows[1].fields["error"].startswith("assumption-violation") and rows[1].fields["verdict"] is None
    assert rows[0].fields["verdict"] == "stable" and rows[2].fields["verdict"] == "stable"


@pytest.mark.slow
def test_two_d_gilbert_elliott_grid_on_the_local_cluster_equals_serial(cluster):
    spec = load_sweep(
        json.dumps(
            {
                "command": "analyze",
                "base": GE,
                "axes": [
                    {"pointer": "/channel/failure_rate", "from": "1/10", "to": "9/10", "num": 5},
                    {"pointer": "/channel/recovery_rate", "from": "1/10", "to": "9/10", "num": 5},
                ],
            }
        )
    )
    dask = run_sweep(spec, scheduler=cluster.scheduler_address, chunk_size=3)
    assert dask.engine == "dask" and dask.workers == 2 and dask.chunks == 9
    assert fields(dask) == fields(run_sweep(spec, engine="serial"))
    # Rohr, Marelli and Fu (2014) Example 2 class, alpha = 2: stable iff 16 ((1-q)^2 + p q) < 1
    for r in dask.rows:
        from fractions import Fraction

        p = Fraction(r.coordinates["/channel/failure_rate"])
        q = Fraction(r.coordinates["/channel/recovery_rate"])
        rate = 16 * ((1 - q) ** 2 + p * q)
        assert r.fields["verdict"] == ("stable" if rate < 1 else "unstable" if rate > 1 else "boundary")


@pytest.mark.slow
def test_a_worker_killed_mid_sweep_loses_and_duplicates_no_row(cluster):
    from distributed import Client

    spec = load_sweep(
        json.dumps(
            {
                "command": "analyze",
                "base": PERIOD_60,
                "axes": [{"pointer": "/channel/arrival_probability", "from": "1/10", "to": "9/10", "num": 8}],
            }
        )
    )
    with Client(cluster.scheduler_address) as client:
        pids = set(client.run(os.getpid).values())
    assert len(pids) == 2
    killed: list[int] = []

    def progress(done, total):
        if not killed and done < total:
            victim = sorted(pids)[0]
            os.kill(victim, signal.SIGKILL)
            killed.append(victim)

    result = run_sweep(spec, scheduler=cluster.scheduler_address, chunk_size=1, reuse=False, progress=progress)
    assert killed, "the sweep finished before a worker could be killed"
    assert [r.index for r in result.rows] == list(range(spec.size))
    assert all(r.fields["error"] is None for r in result.rows)
    assert fields(result) == fields(run_sweep(spec, engine="serial"))
    # the nanny replaced the killed worker process
    cluster.wait_for_workers(2, timeout=60)
    with Client(cluster.scheduler_address) as client:
        assert killed[0] not in set(client.run(os.getpid).values())


def test_cancel_and_budget_give_rows_for_every_point():
    spec = channel_sweep(num=12, options={"chunk_size": 3})
    cancel = threading.Event()

    def progress(done, total):
        cancel.set()

    rows = sorted(iter_sweep(spec, engine="serial", cancel=cancel, progress=progress), key=lambda r: r.index)
    assert [r.index for r in rows] == list(range(12))
    assert all(r.fields["error"] is None for r in rows[:3])
    assert all(r.fields["error"].startswith("cancelled") for r in rows[3:])


def test_exact_boundary_of_a_gilbert_elliott_sweep_is_the_closed_form_curve():
    from kfio.sweep._boundary import exact_boundary

    spec = load_sweep(
        json.dumps(
            {
                "command": "analyze",
                "base": {
                    "system": {"A": [["5/4", 0], [0, "-5/4"]], "C": [[1, 1]]},
                    "channel": {"model": "gilbert_elliott", "failure_rate": "1/10", "recovery_rate": "3/10"},
                },
                "axes": [
                    {"pointer": "/channel/recovery_rate", "values": ["1/2"]},
                    {"pointer": "/channel/failure_rate", "values": ["1/10"]},
                ],
            }
        )
    )
    b = exact_boundary(spec)
    assert b is not None and b["kind"] == "curve"
    pts = [(q, p) for q, p in zip(b["x"], b["y"]) if q is not None]
    assert len(pts) > 10
    # Rohr, Marelli and Fu (2014) Example 2 class: |alpha|^4 ((1-q)^2 + p q) = 1 on the boundary
    for q, p in pts:
        assert (5 / 4) ** 4 * ((1 - q) ** 2 + p * q) == pytest.approx(1, abs=1e-6)


def test_exact_boundary_of_a_two_sensor_sweep_finds_sensors_whose_names_need_escaping():
    """Sensor names with ``/`` and ``~`` are RFC 6901-escaped in the axes' pointers: the curve is still found."""
    from kfio.model import json_pointer
    from kfio.sweep import exact_boundary

    names = ["a/", "b~c"]
    spec = load_sweep(
        json.dumps(
            {
                "command": "analyze",
                "base": {
                    "system": {
                        "A": [["5/2", 0], [0, "3/2"]],
                        "C": [[1, 0], [0, 1]],
                        "sensors": [{"name": n, "rows": [i]} for i, n in enumerate(names)],
                    },
                    "channel": {
                        "model": "per_sensor",
                        "channels": {n: {"model": "bernoulli", "arrival_probability": "9/10"} for n in names},
                    },
                },
                "axes": [
                    {"pointer": json_pointer(("channel", "channels", n, "arrival_probability")), "values": ["9/10"]}
                    for n in names
                ],
            }
        )
    )
    b = exact_boundary(spec)
    assert b is not None and b["kind"] == "curve" and len(b["x"]) > 2
