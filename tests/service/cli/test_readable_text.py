"""Summaries, reprs and help read well and headline the exact verdict.

Before: ``kfio simulate --help`` showed "95%% band"; a simulation summary led
with Monte Carlo; reprs embedded ``CRootOf(1562500000...*x**3 - ...)`` and
``'2501225941561293/2500000000000000'``; an unreachable outage target read
"smallest lambda about none in [0, 1] ... between none in [0, 1] and none in
[0, 1]"; a long tail exponent said "exact closed form: see --json".  The JSON
of every report is unchanged: only the text views are.
"""

from __future__ import annotations

import dataclasses
import json
import re
from fractions import Fraction

import pytest

from kfio import System, analyze, load_request
from kfio.service.cli import build_parser
from kfio.simulation._simulate import simulate

from support.paths import ROOT

EXAMPLES = ROOT / "examples"


def _helps() -> dict[str, str]:
    parser = build_parser()
    (sub,) = [a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction"]
    return {"kfio": parser.format_help(), **{name: p.format_help() for name, p in sub.choices.items()}}


def test_rendered_help_has_no_doubled_percent_signs() -> None:
    helps = _helps()
    assert {"analyze", "bounds", "simulate", "sweep", "serve"} <= set(helps)
    for name, text in helps.items():
        assert "%%" not in text, name
    assert "95% band" in helps["simulate"] and "90% and 99%" in helps["simulate"].replace("\n", " ")
    assert "95% band" in helps["kfio"]


def _bursty(**sim):
    body = json.loads((EXAMPLES / "simulate_bursty_ge.json").read_text())
    body["options"]["simulate"] = {"steps": 20, "trajectories": 300, "seed": 1, **sim}
    return load_request(json.dumps(body))


def test_simulate_summary_and_repr_lead_with_the_exact_verdict() -> None:
    report = simulate(_bursty())
    first = report.summary().splitlines()[0]
    assert first == (
        "UNSTABLE (exact, Rohr, Marelli and Fu 2014, Theorem 1). "
        "Monte Carlo: sample mean unreliable (kappa = 0.44 <= 2); read the quantiles"
    )
    assert report.to_dict()["stationary"]["verdict"] == "unstable"
    assert repr(report).startswith("SimulationReport(exact_verdict='unstable', steps=20,")
    # without the exact analysis (it failed or ran out of budget) the summary says so, and never claims a verdict
    bare = dataclasses.replace(report, stationary=None)
    assert bare.summary().splitlines()[0].startswith("exact verdict not computed")
    assert repr(bare).startswith("SimulationReport(exact_verdict='not computed',")


def test_unreachable_outage_target_says_so_plainly() -> None:
    # P_T >= Q = 1 on every path, so P(trace P > 1/2) = 1 at every lambda: no lambda in [0, 1] meets it
    report = simulate(_bursty_bernoulli({"threshold": 0.5, "epsilon": 0.1}))
    assert report.outage_target.estimate is None
    (line,) = report.outage_target.summary_lines()
    assert "none in" not in line
    assert "cannot be reached for any lambda in [0, 1]" in line
    assert "even when every packet arrives (lambda = 1) the outage exceeds 0.1 (estimated outage 1)" in line
    assert report.to_dict()["outage_target"]["smallest_arrival_probability_estimate"] is None


def _bursty_bernoulli(target):
    return load_request(
        json.dumps(
            {
                "system": {"A": [[1.3]], "C": [[1]], "Q": [[1]], "R": [[1]]},
                "channel": {"model": "bernoulli", "arrival_probability": 0.5},
                "options": {"simulate": {"steps": 8, "trajectories": 200, "outage_target": target}},
            }
        )
    )


@pytest.fixture(scope="module")
def pendulum():
    return analyze(load_request((EXAMPLES / "pendulum_c2d.json").read_text()))


def test_reprs_show_algebraic_numbers_as_decimals_with_their_degree(pendulum) -> None:
    text = repr(pendulum)
    assert "CRootOf" not in text and "root of x**3" not in text
    assert "critical_arrival_probability_exact='root of a degree-3 polynomial, 0.0544201'" in text
    assert "BlockReport(eigenvalues=('root of a degree-3 polynomial, 1.02837',)" in text
    assert len(text) < 700
    # the exact texts stay in to_dict()
    d = pendulum.to_dict()
    assert d["critical_arrival_probability_exact"].startswith("1 - 1/CRootOf(")
    assert d["blocks"][0]["eigenvalues"][0].startswith("root of x**3 - 29760910099694437*x**2/")


def test_long_tail_exponent_says_what_kind_of_number_it_is(pendulum) -> None:
    (line,) = [ln for ln in pendulum.summary().splitlines() if ln.startswith("tail exponent")]
    assert "see --json" not in line and "(exact" not in line
    m = re.match(r"tail exponent kappa = (\S+) \(from float data\): ", line)
    assert m, line
    assert float(m.group(1)) == pytest.approx(pendulum.tail.kappa, rel=1e-5) and m.group(1) == "12.3872"
    assert len(pendulum.to_dict()["tail"]["kappa_exact"]) > 40


def test_system_repr_shortens_long_fractions_and_to_dict_keeps_them() -> None:
    plant = System(A=[[1.0004897194771216, "2501225941561293/2500000000000000"], [0, "11/10"]], C=[[1, 0]])
    assert repr(plant) == "System(A=[['~1.00049', '~1.00049'], ['0', '11/10']], C=[['1', '0']])"
    exact = Fraction("1.0004897194771216")
    assert plant.to_dict()["A"][0] == [f"{exact.numerator}/{exact.denominator}", "2501225941561293/2500000000000000"]


def test_bounds_summary_says_it_computes_no_exact_verdict() -> None:
    from kfio.riccati_bounds._compute import compute_bounds

    report = compute_bounds(load_request((EXAMPLES / "seed004_scalar.json").read_text()))
    first = report.summary().splitlines()[0]
    assert first.startswith("exact verdict: not computed here (kfio analyze gives it")
    assert "verdict" not in report.to_dict() or report.to_dict()["verdict"] == report.verdict


def test_gilbert_elliott_summary_shows_long_exact_numbers_as_decimals() -> None:
    import re

    report = analyze(
        load_request(
            json.dumps(
                {
                    "system": {"A": [[1.2504897194771216, 0], [0, -1.2504897194771216]], "C": [[1, 1]]},
                    "channel": {"model": "gilbert_elliott", "failure_rate": 0.30000123456789, "recovery_rate": 0.5},
                }
            )
        )
    )
    text = report.summary()
    assert not re.search(r"\d{13}", text), text  # no 13-digit numerators, denominators or coefficients
    assert "eigenvalues ~1.25049, ~-1.25049:" in text
    m = re.search(r"critical recovery rate q at p = ~0\.300001: (\S+) \(algebraic, degree 2, from float data\) ", text)
    assert m, text
    crossing = report.to_dict()["gilbert_elliott_region"]["critical_recovery_rate"]["crossings"][0]
    assert float(m.group(1)) == pytest.approx(crossing["value"], rel=1e-5) and m.group(1) == "0.487428"
    assert "sqrt(" in crossing["value_exact"] and "(exact" not in text
    assert report.to_dict()["blocks"][0]["eigenvalues"][0] == "781556074673201/625000000000000"
