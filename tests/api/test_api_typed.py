"""The typed API: ``kfio.Verdict`` members in the reports, exact values as ``Fraction`` or ``kfio.ExactReal``.

The JSON keeps the plain texts; a report's ``exact_of`` gives the object.
Every rational value is checked against an independent route: the exact
verdict just above, at and just below it.
"""

from __future__ import annotations

import dataclasses
import json
from fractions import Fraction

import pytest

import kfio
from kfio._reporting import ReportPart


def scalar(a: Fraction | int) -> kfio.System:
    return kfio.System(A=[[a]], C=[[1]], Q=[[1]], R=[[1]])


@pytest.mark.parametrize("a", [Fraction(5, 4), Fraction(-7, 3), Fraction(11, 10), 3])
def test_the_critical_probability_is_a_fraction_where_the_verdict_changes(a: Fraction | int) -> None:
    report = kfio.analyze(scalar(a), kfio.bernoulli("1/2"))
    crit = report.exact_of("critical_arrival_probability")
    assert isinstance(crit, Fraction) and crit == 1 - Fraction(1) / Fraction(a) ** 2  # 1 - 1/a^2
    assert float(crit) == report.critical_arrival_probability
    assert report.exact_of("critical_arrival_probability_exact") == crit  # the text's name works too
    eps = Fraction(1, 10**6)
    verdicts = [kfio.analyze(scalar(a), kfio.bernoulli(p)).verdict for p in (crit + eps, crit, crit - eps)]
    assert verdicts == [kfio.Verdict.STABLE, kfio.Verdict.BOUNDARY, kfio.Verdict.UNSTABLE]
    assert all(type(v) is kfio.Verdict for v in verdicts)


def test_block_values_are_exact_objects() -> None:
    # period-2 block (eigenvalues +-sqrt(2)) seen at one phase of two: sigma = (1 - p)^(1/2), algebraic
    report = kfio.analyze(kfio.System(A=[[0, 2], [1, 0]], C=[[1, 0]]), kfio.bernoulli("9/10"))
    (block,) = report.blocks
    assert block.exact_names() == ("modulus", "sigma") and type(block.verdict) is kfio.Verdict
    sigma = block.exact_of("sigma")
    assert isinstance(sigma, kfio.ExactReal) and str(sigma) == block.sigma_exact
    assert float(sigma) == block.sigma and abs(float(sigma) ** 2 - 0.1) < 1e-15  # sigma^N = 1 - p
    assert isinstance(block.exact_of("modulus"), kfio.ExactReal)  # sqrt(2)
    assert report.exact_of("critical_arrival_probability") == Fraction(3, 4)  # 1 - 1/|alpha|^4


def test_missing_and_unknown_exact_values() -> None:
    report = kfio.analyze(scalar(2), kfio.gilbert_elliott(failure_rate="1/10", recovery_rate="3/5"))
    assert report.exact_of("critical_arrival_probability") is None  # a Bernoulli-only value
    with pytest.raises(AttributeError, match="no exact value 'verdict'; it has: critical_arrival_probability"):
        report.exact_of("verdict")


def test_exact_value_reads_text_and_never_evaluates_it() -> None:
    assert kfio.exact_value("-3/7") == Fraction(-3, 7) and kfio.exact_value("12") == Fraction(12)
    x = kfio.exact_value("__import__('os').getcwd()", 0.25)
    assert isinstance(x, kfio.ExactReal) and str(x) == "__import__('os').getcwd()" and float(x) == 0.25
    with pytest.raises(OverflowError, match="no float64 value"):
        float(kfio.exact_value("10**400"))


def test_verdicts_are_enum_members_and_the_json_is_plain_text() -> None:
    report = kfio.analyze(scalar(Fraction(5, 4)), kfio.bernoulli("9/25"))
    assert report.verdict is kfio.Verdict.BOUNDARY and report.verdict == "boundary"
    data = report.to_dict()
    assert type(data["verdict"]) is str and type(data["blocks"][0]["verdict"]) is str
    assert json.loads(report.to_json())["verdict"] == "boundary"
    assert repr(report).startswith("StabilityReport(verdict='boundary'")  # the repr shows the JSON text
    assert [m.value for m in kfio.Verdict] == ["stable", "boundary", "unstable", "undecided"]


def test_bounds_verdict_is_an_enum_member() -> None:
    b = kfio.bounds(kfio.System(A=[[-1.25]], C=[[1]], Q=[[1]], R=[[2.5]]), kfio.bernoulli(0.4))
    assert b.verdict is kfio.Verdict.STABLE and b.to_dict()["operating_point"]["verdict_by_bounds"] == "stable"


def test_build_request_returns_the_public_request() -> None:
    req = kfio.build_request(scalar(2), kfio.bernoulli("1/2"), command="analyze", options={"ge_grid": 3}, budget=9)
    assert isinstance(req, kfio.Request) and req.time_budget_s == 9 and req.options == {"analyze": {"ge_grid": 3}}


def test_one_public_name_per_concept() -> None:
    import kfio.model
    import kfio.riccati_bounds

    assert "compute_bounds" not in kfio.__all__ and not hasattr(kfio, "compute_bounds")
    assert "System" not in kfio.model.__all__ and not hasattr(kfio.model, "System")
    assert (
        kfio.riccati_bounds.compute_bounds is not kfio.bounds
    )  # the request-level engine under kfio.riccati_bounds only


def _parts(value: object) -> list[ReportPart]:
    """Every report part inside ``value`` (fields of dataclasses, tuples, lists and dicts), depth first."""
    found: list[ReportPart] = []
    if isinstance(value, ReportPart):
        found.append(value)
        if dataclasses.is_dataclass(value):
            for f in dataclasses.fields(value):
                found += _parts(getattr(value, f.name))
    elif isinstance(value, (tuple, list)):
        for v in value:
            found += _parts(v)
    elif isinstance(value, dict):
        for v in value.values():
            found += _parts(v)
    return found


def test_every_exact_text_of_every_part_reads_as_its_float() -> None:
    ge = kfio.gilbert_elliott(failure_rate="1/10", recovery_rate="3/5")
    two = kfio.System(A=[[2, 0], [0, 3]], C=[[1, 0], [0, 1]], sensors={"a": [0], "b": [1]})
    reports = [
        kfio.analyze(kfio.System(A=[[1.25, 0], [1, 1.1]], C=[[1, 1]]), ge, options={"ge_grid": 3}),
        kfio.analyze(two, kfio.per_sensor({"a": 0.9, "b": 0.95})),
        kfio.analyze(kfio.System(A=[[0, 2], [1, 0]], C=[[1, 0]]), kfio.bernoulli("9/10")),
    ]
    checked = 0
    for part in [p for r in reports for p in _parts(r)]:
        for name in part.exact_names():
            value, text = part.exact_of(name), getattr(part, name + "_exact")
            approx = getattr(part, name, None)
            if value is None:
                assert text is None
                continue
            if isinstance(value, Fraction):
                assert str(value) == text.replace(" ", "")
            else:
                assert isinstance(value, kfio.ExactReal) and value.text == text
            if isinstance(approx, float):
                assert float(value) == pytest.approx(approx, rel=1e-12, abs=1e-300)
            checked += 1
    assert checked >= 10
