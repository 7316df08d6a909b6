"""The per-plant memo of a sweep: the cached analysis equals the uncached one, point by point.

``analyze(..., fmo=, memo=)`` keeps what depends on the plant alone (the
rank tests, the blind sets of every channel-independent search route, the
Pareto front of several Bernoulli sensors, the exact rank checks, the
critical probability of one Bernoulli packet, ``log beta``...).  Each test
runs a sequence of channels on one plant through one memo and compares every
report, as JSON, with a fresh analysis that has no memo; and the sweep's row
(:func:`kfio.sweep._rows.analyze_row`, which encodes only the row's fields)
with the row read off the whole report.
"""

from __future__ import annotations

import json
import random
from fractions import Fraction

import pytest

from kfio import load_request
from kfio._reuse import clear_plants, reused_plant, structure_cache, structure_key
from kfio.stability import analyze
from kfio.structure import fmo_blocks
from kfio.sweep import clear_caches
from kfio.sweep._evaluate import evaluate_point
from kfio.sweep._rows import analyze_row, row_from_report

#: Plants with one packet: scalar, real and complex modes, a degenerate pair (eigenvalues 2 and -2), a stable mode.
ONE_SENSOR = [
    ([[Fraction(5, 4), 0], [1, Fraction(11, 10)]], [[1, 1]]),
    ([[2, 0], [0, -2]], [[1, 1]]),
    ([[0, -2], [2, 0]], [[1, 0]]),
    ([[Fraction(3, 2), 1, 0], [0, Fraction(1, 2), 0], [0, 0, -Fraction(6, 5)]], [[1, 0, 1]]),
]
#: Plants with two sensors; the cyclic ones have a Pareto front whose worst set depends on the probabilities.
TWO_SENSORS = [
    ([[0, 0, 2], [2, 0, 0], [0, 2, 0]], [[1, 0, 0], [0, 1, 1]]),
    ([[0, 0, 2], [2, 0, 0], [0, 2, 0]], [[1, 1, 0], [0, 1, 0]]),
    ([[2, 0], [0, -2]], [[1, 1], [1, -1]]),
]


def _text(x) -> str:
    x = Fraction(x)
    return str(x.numerator) if x.denominator == 1 else f"{x.numerator}/{x.denominator}"


def _system(A, C, sensors: bool) -> dict:
    s = {"A": [[_text(x) for x in row] for row in A], "C": [[_text(x) for x in row] for row in C]}
    if sensors:
        s["sensors"] = [{"name": f"s{i}", "rows": [i]} for i in range(len(C))]
    return s


def _p(rng: random.Random) -> str:
    return f"{rng.randint(1, 99)}/100"


def _channel(kind: str, rng: random.Random) -> dict:
    if kind == "bernoulli":
        return {"model": "bernoulli", "arrival_probability": _p(rng)}
    if kind == "gilbert_elliott":
        return {"model": "gilbert_elliott", "failure_rate": _p(rng), "recovery_rate": _p(rng)}
    return {
        "model": "markov",
        "order": 2,
        "arrival_probability": {h: _p(rng) for h in ("00", "01", "10", "11")},
    }


def _same_as_uncached(requests: list[dict]) -> list:
    """Analyse ``requests`` (one plant) through one memo; assert each equals the uncached analysis."""
    first = load_request(json.dumps(requests[0]))
    fmo, memo = fmo_blocks(first.system), {}
    reports = []
    for tree in requests:
        req = load_request(json.dumps(tree))
        cached = analyze(req, fmo=fmo, memo=memo)
        fresh = analyze(req)
        assert cached.to_dict() == fresh.to_dict(), tree
        assert analyze_row(cached) == row_from_report("analyze", fresh.to_dict())
        light = analyze(req, fmo=fmo, memo=memo, tail="kappa")  # what a sweep row runs
        assert analyze_row(light) == row_from_report("analyze", fresh.to_dict()), tree
        assert {k: v for k, v in light.to_dict().items() if k != "tail"} == {
            k: v for k, v in fresh.to_dict().items() if k != "tail"
        }
        reports.append(cached)
    assert memo, "the memo kept nothing: the test would not test it"
    return reports


@pytest.mark.parametrize(("A", "C"), ONE_SENSOR)
@pytest.mark.parametrize("kind", ["bernoulli", "gilbert_elliott", "markov"])
def test_one_packet_cached_equals_uncached(A, C, kind):
    rng = random.Random(f"{A}{C}{kind}")
    system = _system(A, C, sensors=False)
    _same_as_uncached([{"system": system, "channel": _channel(kind, rng)} for _ in range(4)])


@pytest.mark.slow
@pytest.mark.parametrize(("A", "C"), TWO_SENSORS)
def test_two_sensors_cached_equals_uncached(A, C):
    """Several Bernoulli sensors (the Pareto route), and a Gilbert-Elliott sensor beside one (the orbits route)."""
    rng = random.Random(f"{A}{C}")
    system = _system(A, C, sensors=True)
    trees = []
    for i in range(5):
        second = "bernoulli" if i < 3 else "gilbert_elliott"
        channels = {"s0": _channel("bernoulli", rng), "s1": _channel(second, rng)}
        trees.append({"system": system, "channel": {"model": "per_sensor", "channels": channels}})
    _same_as_uncached(trees)


def test_the_worst_set_on_a_kept_front_follows_the_probabilities():
    """The front is kept, not its argmax: two channels on one plant pick different worst sets, each as uncached."""
    A, C = TWO_SENSORS[0]
    system = _system(A, C, sensors=True)

    def tree(p0: str, p1: str) -> dict:
        channels = {
            "s0": {"model": "bernoulli", "arrival_probability": p0},
            "s1": {"model": "bernoulli", "arrival_probability": p1},
        }
        return {"system": system, "channel": {"model": "per_sensor", "channels": channels}}

    reports = _same_as_uncached([tree("1/10", "9/10"), tree("9/10", "1/10")])
    sets = [[b.blind_set for b in r.blocks] for r in reports]
    assert sets[0] != sets[1]


def test_plants_equal_as_floats_never_share_a_memo():
    """``11/10`` and the double nearest to it are one float but two plants: two memos, two answers."""
    double = Fraction(1.1)
    assert double != Fraction(11, 10) and float(double) == 1.1
    clear_caches()
    rows = []
    for a in ("11/10", _text(double)):
        tree = {
            "system": {"A": [[a]], "C": [["1"]]},
            "channel": {"model": "bernoulli", "arrival_probability": "1/2"},
        }
        cached = evaluate_point("analyze", tree, 60.0)
        assert cached == evaluate_point("analyze", tree, 60.0, reuse=False)
        rows.append(cached)
    assert rows[0]["critical_arrival_probability_exact"] != rows[1]["critical_arrival_probability_exact"]
    assert len(structure_cache().data) == 2
    channel = {"model": "bernoulli", "arrival_probability": "1/2"}
    keys = [
        structure_key(load_request(json.dumps({"system": {"A": [[a]], "C": [["1"]]}, "channel": channel})).system)
        for a in ("1.1", "11/10", _text(double))
    ]
    assert keys[0] == keys[1] != keys[2]  # the decimal text 1.1 is the rational 11/10: one plant


def test_reused_plant_keeps_one_memo_per_plant():
    clear_plants()
    channel = '"channel": {"model": "bernoulli", "arrival_probability": 0.5}'
    a = load_request('{"system": {"A": [[2]], "C": [[1]]}, ' + channel + "}").system
    b = load_request('{"system": {"A": [[3]], "C": [[1]]}, ' + channel + "}").system
    (fa, ma), (fa2, ma2), (fb, mb) = reused_plant(a), reused_plant(a), reused_plant(b)
    assert fa is fa2 and ma is ma2
    assert ma is not mb and fa is not fb
    same = load_request('{"system": {"A": [[2]], "C": [[1]]}, ' + channel + "}").system
    assert same is not a and reused_plant(same)[1] is ma  # an equal plant, another object: the same memo
    assert reused_plant(b)[1] is mb


@pytest.mark.parametrize(
    "value",
    ["stable", 3, True, None, 0.25, float("nan"), float("inf"), (1, 2), [0.5, None], {"a": 1}],
)
def test_a_record_skips_the_encoder_only_when_it_would_change_nothing(value):
    import numpy as np

    from kfio.sweep import record
    from kfio.sweep._engine import SweepRow

    for v in (value, np.float64(0.75), np.int64(2)):
        row = SweepRow(4, {"p": "1/2", "k": 3}, {"verdict": v, "error": None})
        columns = ["index", "axis:p", "axis:k", "verdict", "error"]
        d = row.to_dict()
        assert record(row, columns) == {c: d.get(c) for c in columns}
        assert [type(x) for x in record(row, columns).values()] == [type(d.get(c)) for c in columns]


def test_the_streamed_csv_is_the_dict_writer_csv(tmp_path):
    """Rows go through the plain CSV writer: the same bytes as ``csv.DictWriter`` (quotes, booleans, empty None)."""
    from kfio.sweep._table import TableWriter, csv_text

    columns = ["index", "axis:p", "verdict", "worst_rate", "certified", "error"]
    records = [
        {"index": i, "axis:p": "1/3", "verdict": 'a "b", c', "worst_rate": 0.1 * i, "certified": i % 2 == 0}
        | {"error": None if i else "internal: x\ny"}
        for i in range(5)
    ]
    path = tmp_path / "t.csv"
    with TableWriter(path, columns) as w:
        for r in records:
            w.write(r)
    assert path.read_text(encoding="utf-8") == csv_text(columns, records)


def _clear_value_caches() -> None:
    from kfio.design._tail import _log_rational
    from kfio.sigma._decide import _bernoulli_factor
    from kfio.stability._verdict import _radical_float

    for cached in (_log_rational, _bernoulli_factor, _radical_float):
        cached.cache_clear()


def test_value_caches_shared_across_plants_leave_every_row_unchanged():
    """``sigma^N``, its float and ``log sigma^N`` are kept per exact value; on a second plant they are hit.

    Every row (plant memo and value caches warm) equals the row of an uncached
    analysis run with those caches emptied first.
    """
    from kfio.design._tail import _log_rational
    from kfio.stability._verdict import _radical_float

    clear_caches()
    _clear_value_caches()
    trees = [
        {
            "system": {"A": [[a, "0"], ["1", "1.1"]], "C": [["1", "1"]]},
            "channel": {"model": "bernoulli", "arrival_probability": p},
        }
        for a in ("1.25", "1.3", "-1.4")
        for p in ("1/100", "37/100", "1/2", "0.93")
    ]
    cached = [evaluate_point("analyze", tree, 60.0) for tree in trees]
    assert _log_rational.cache_info().hits > 0 and _radical_float.cache_info().hits > 0  # else nothing is tested
    for tree, row in zip(trees, cached):
        _clear_value_caches()
        assert row == evaluate_point("analyze", tree, 60.0, reuse=False), tree
