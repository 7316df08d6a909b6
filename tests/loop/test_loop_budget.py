"""Budgets inside the loop library: the verdict raises BudgetExceeded when it does not fit; later parts make a partial report."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import kfio
from kfio.errors import BudgetExceeded
from kfio.loop import analyze_loop, load_loop_request, loop_mjls, loop_request, parse_loop_request
from kfio.loop._verdict import decide

ROOT = Path(__file__).resolve().parents[2]


def _request():
    return parse_loop_request(json.loads((ROOT / "examples" / "loop_scalar.json").read_text()))


def _verdict_steps(req) -> int:
    counter = kfio.Budget()
    decide(loop_mjls(req), counter)
    return counter.steps


def test_a_budget_spent_before_the_verdict_raises_naming_the_step():
    req = _request()
    with pytest.raises(BudgetExceeded) as err:
        analyze_loop(req, budget=kfio.Budget(max_steps=_verdict_steps(req) - 1))
    assert "loop verdict" in str(err.value)


def test_a_budget_spent_after_the_verdict_gives_a_partial_report_with_the_verdict_and_cost():
    req = _request()
    full = analyze_loop(req)
    part = analyze_loop(req, budget=kfio.Budget(max_steps=_verdict_steps(req)))
    assert part.partial and not full.partial
    assert (part.verdict, part.stationary_cost) == (full.verdict, full.stationary_cost)
    assert part.critical_sensor_arrival_probability is None and full.critical_sensor_arrival_probability_exact == "9/16"
    assert all(c.note.startswith("not computed: the time budget ran out") for c in part.critical)
    out = part.to_dict()
    assert out["partial"] is True and any(n.startswith("partial: the time budget ran out") for n in out["notes"])
    assert out["estimator_alone"]["verdict"] == full.estimator_alone.verdict


def test_seconds_reach_the_library_through_options_time_budget_s():
    body = json.loads((ROOT / "examples" / "loop_scalar.json").read_text())
    body["options"]["time_budget_s"] = "60"
    req = load_loop_request(json.dumps(body))
    assert req.time_budget_s == 60
    rep = analyze_loop(req)
    assert not rep.partial and rep.critical_sensor_arrival_probability_exact == "9/16"
    tree = loop_request(
        kfio.System(A=[[1.25]], C=[[1]], Q=[[1]], R=[[1]]),
        feedback=[[0.6]],
        estimator=[[0.5]],
        channel=kfio.bernoulli(0.8),
        actuator_channel=kfio.bernoulli(0.9),
        B=[[1]],
        budget=30,
    )
    assert tree["options"]["time_budget_s"] == 30
