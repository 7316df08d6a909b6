"""Request parsing and validation: exact numbers, clear errors naming the field."""

from __future__ import annotations

import json
from decimal import Decimal
from fractions import Fraction

import pytest

from kfio import InvalidInput, LimitExceeded, Limits, load_request, parse_number
from kfio.model._exact import load_json

GOOD = {
    "system": {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]], "Q": [[20, 0], [0, 20]], "R": [[2.5]]},
    "channel": {"model": "bernoulli", "arrival_probability": 0.5},
}


def body(**changes):
    b = json.loads(json.dumps(GOOD))
    for path, value in changes.items():
        keys = path.split("__")
        d = b
        for k in keys[:-1]:
            d = d[k]
        if value is _DELETE:
            del d[keys[-1]]
        else:
            d[keys[-1]] = value
    return json.dumps(b)


_DELETE = object()


def test_json_numbers_are_their_decimal_text():
    r = load_request(json.dumps(GOOD))
    assert r.system.A[1][1] == Fraction(11, 10)  # not the double nearest 1.1
    assert r.system.R[0][0] == Fraction(5, 2)
    assert load_json("1.1") == Decimal("1.1")


@pytest.mark.parametrize(
    "text, value",
    [
        ("11/10", Fraction(11, 10)),
        ("-3/4", Fraction(-3, 4)),
        ("1.1e-3", Fraction(11, 10000)),
        ("-0", Fraction(0)),
        ("2.5/0.5", Fraction(5)),
        ("1E2", Fraction(100)),
        (".5", Fraction(1, 2)),
    ],
)
def test_number_strings(text, value):
    assert parse_number(text, "/x") == value


@pytest.mark.parametrize(
    "bad, rule",
    [
        ("__import__('os').system('id')", "not a number"),
        ("1/0", "division by zero"),
        ("nan", "not a number"),
        ("inf", "not a number"),
        ("sqrt(2)", "not a number"),
        ("", "not a number"),
        (True, "expected a number"),
        (None, "expected a number"),
        ([1], "expected a number"),
    ],
)
def test_bad_numbers(bad, rule):
    with pytest.raises(InvalidInput, match=rule) as e:
        parse_number(bad, "/system/A/0/0")
    assert e.value.field == "/system/A/0/0"


def test_digit_limit():
    with pytest.raises(LimitExceeded, match="200 digits"):
        parse_number("1" * 201, "/x")
    with pytest.raises(LimitExceeded):
        parse_number("1e999999999", "/x")
    assert parse_number("1" * 200, "/x") == int("1" * 200)


@pytest.mark.parametrize(
    "text, field, rule",
    [
        (body(system__A=[[1, 2, 3], [4, 5, 6]]), "/system/A", "square"),
        (body(system__C=[[1, 1, 1]]), "/system/C", "2 columns"),
        (body(system__A=[[1, 0], [1]]), "/system/A/1", "row 1"),
        (body(system__Q=[[1, 2], [3, 1]]), "/system/Q/0/1", "symmetric"),
        (body(system__Q=[[1, 2], [2, 1]]), "/system/Q", "positive semidefinite"),
        (body(system__Q=[[1, 0, 0], [0, 1, 0], [0, 0, 1]]), "/system/Q", "2x2"),
        (body(system__R=[[0]]), "/system/R", "positive definite"),
        (body(system__R=[[1, 0], [0, 1]]), "/system/R", "1x1"),
        (body(system__A=[[True, 0], [1, 1]]), "/system/A/0/0", "expected a number"),
        (body(system__A=[[None, 0], [1, 1]]), "/system/A/0/0", "expected a number"),
        (body(system__A=[["__import__('os').system('id')", 0], [1, 1]]), "/system/A/0/0", "not a number"),
        (body(channel__arrival_probability=1.5), "/channel/arrival_probability", r"\[0, 1\]"),
        (body(channel__arrival_probability=-0.1), "/channel/arrival_probability", r"\[0, 1\]"),
        (body(channel__model="smoke"), "/channel/model", "unknown channel model"),
        (body(channel__extra=1), "/channel/extra", "unknown field"),
        (body(system__B=[[1]]), "/system/B", "unknown field"),
        (body(system__A=_DELETE), "/system/A", "required"),
        (body(channel=_DELETE), "/channel", "required"),
        ('{"system": 1, "channel": {}}', "/system", "object"),
        ("[1, 2]", "/", "object"),
        ("{", "/", "not valid JSON"),
        ('{"a": NaN}', "/", "NaN"),
        ('{"system": {}, "system": {}}', "/", "duplicate"),
        ("[" * 100000, "/", "nested too deeply"),
    ],
)
def test_bad_requests_name_field_and_rule(text, field, rule):
    with pytest.raises(InvalidInput, match=rule) as e:
        load_request(text)
    assert e.value.field == field


def test_markov_tables():
    ch = {"model": "markov", "order": 2, "arrival_probability": {"00": 0.1, "01": "1/2", "10": 0.3, "11": 0.9}}
    r = load_request(body(channel=ch))
    assert r.channel.table == (Fraction(1, 10), Fraction(1, 2), Fraction(3, 10), Fraction(9, 10))
    # history "01": g[t-2] = 0, g[t-1] = 1 is index 1; emitting g shifts it left
    assert r.channel.next_history(1, 1) == 3 and r.channel.next_history(2, 0) == 0
    missing = dict(ch, arrival_probability={"00": 0.1, "01": 0.5, "10": 0.3})
    with pytest.raises(InvalidInput, match="missing histories: '11'"):
        load_request(body(channel=missing))
    extra = dict(ch, arrival_probability={**ch["arrival_probability"], "111": 0.5})
    with pytest.raises(InvalidInput, match="2 characters") as e:
        load_request(body(channel=extra))
    assert e.value.field == "/channel/arrival_probability/111"
    with pytest.raises(LimitExceeded, match="limit 10"):
        load_request(body(channel={"model": "markov", "order": 11, "arrival_probability": {}}))


def test_gilbert_elliott_is_order_one_markov():
    r = load_request(body(channel={"model": "gilbert_elliott", "failure_rate": "1/5", "recovery_rate": "3/10"}))
    # table[h] = P(arrive | previous h): after a loss q, after an arrival 1 - p
    assert r.channel.order == 1 and r.channel.table == (Fraction(3, 10), Fraction(4, 5))
    assert abs(r.channel.mean_arrival_rate() - 0.3 / 0.5) < 1e-12


def test_size_limits_are_configurable():
    big = [[1 if i == j else 0 for j in range(41)] for i in range(41)]
    with pytest.raises(LimitExceeded, match="limit is 40"):
        load_request(body(system__A=big, system__C=[[1] * 41], system__Q=_DELETE))
    small = Limits(max_states=1)
    with pytest.raises(LimitExceeded):
        load_request(json.dumps(GOOD), small)


def test_sensors_partition_rows():
    base = {
        "system": {
            "A": [[2, 0], [0, 3]],
            "C": [[1, 0], [0, 1]],
            "sensors": [{"name": "a", "rows": [0]}, {"name": "b", "rows": [1]}],
        },
        "channel": {
            "model": "per_sensor",
            "channels": {
                "a": {"model": "bernoulli", "arrival_probability": 0.5},
                "b": {"model": "bernoulli", "arrival_probability": 0.7},
            },
        },
    }
    r = load_request(json.dumps(base))
    assert r.channel.for_sensor("b").table == (Fraction(7, 10),)
    b2 = json.loads(json.dumps(base))
    b2["system"]["sensors"][1]["rows"] = [0]
    with pytest.raises(InvalidInput, match="already carried") as e:
        load_request(json.dumps(b2))
    assert e.value.field == "/system/sensors/1/rows/0"
    b3 = json.loads(json.dumps(base))
    b3["channel"]["channels"]["c"] = {"model": "bernoulli", "arrival_probability": 0.5}
    with pytest.raises(InvalidInput, match="unknown sensor 'c'"):
        load_request(json.dumps(b3))
    b4 = json.loads(json.dumps(base))
    b4["system"]["sensors"] = [{"name": "a", "rows": [0]}]
    b4["channel"]["channels"] = {"a": {"model": "bernoulli", "arrival_probability": 0.5}}
    with pytest.raises(InvalidInput, match=r"rows \[1\] are carried by no sensor"):
        load_request(json.dumps(b4))
    b5 = json.loads(json.dumps(base))
    b5["channel"] = {"model": "bernoulli", "arrival_probability": 0.5}
    with pytest.raises(InvalidInput, match="per_sensor"):
        load_request(json.dumps(b5))


def test_options_groups():
    r = load_request(body(options={"bounds": {"tolerance": 1e-6}, "time_budget_s": 5}))
    assert r.options["bounds"] == {"tolerance": Decimal("0.000001")} and r.time_budget_s == 5.0
    with pytest.raises(InvalidInput, match="unknown field") as e:
        load_request(body(options={"colour": {}}))
    assert e.value.field == "/options/colour"
    for tiny in (0, "1e-199", 0.009):  # below the documented minimum of 0.01 s
        with pytest.raises(InvalidInput, match=r"\[0.01, 3600\]"):
            load_request(body(options={"time_budget_s": tiny}))
    assert load_request(body(options={"time_budget_s": 0.01})).time_budget_s == 0.01


def test_json_pointer_escapes_keys():
    # RFC 6901: "~" -> "~0", "/" -> "~1"
    with pytest.raises(InvalidInput) as e:
        load_request(body(system__extra_a=None).replace('"extra_a"', '"a/b~c"'))
    assert e.value.field == "/system/a~1b~0c"


def test_definiteness_filter_and_exact_fallback():
    from kfio.model._request import is_psd

    m = lambda rows: tuple(tuple(Fraction(x) for x in r) for r in rows)  # noqa: E731
    assert is_psd(m([[1, 0], [0, 0]]), strict=False) and not is_psd(m([[1, 0], [0, 0]]), strict=True)
    # singular PSD with tiny off-diagonal structure: only the exact route can tell
    eps = Fraction(1, 10**40)
    assert is_psd(m([[1, eps], [eps, eps * eps]]), strict=False)
    assert not is_psd(m([[1, eps], [eps, eps * eps - Fraction(1, 10**120)]]), strict=False)
    assert not is_psd(m([[0, 1], [1, 0]]), strict=False)
