"""Bad input for the bounds: every error names its field (kfio.riccati_bounds._options)."""

from __future__ import annotations

import json

import pytest

from kfio import InvalidInput, LimitExceeded, load_request
from kfio.riccati_bounds._compute import compute_bounds
from kfio.riccati_bounds._options import parse_bounds_options

SYSTEM = {"A": [[-1.25]], "C": [[1]], "Q": [[1]], "R": [[2.5]]}
BERNOULLI = {"model": "bernoulli", "arrival_probability": 0.4}


def body(system=None, channel=None, bounds=None) -> dict:
    out = {"system": system or SYSTEM, "channel": channel or BERNOULLI}
    if bounds is not None:
        out["options"] = {"bounds": bounds}
    return out


def options(b: dict, flags=None):
    return parse_bounds_options(load_request(json.dumps(b)), flags)


def two_sensor_system() -> dict:
    return {
        "A": [[1.25, 0], [1, 1.1]],
        "C": [[1, 0], [1, 1]],
        "Q": [[1, 0], [0, 1]],
        "R": [[1, 0], [0, 1]],
        "sensors": [{"name": "gps", "rows": [0]}, {"name": "wheel", "rows": [1]}],
    }


PER_SENSOR = {"model": "per_sensor", "channels": {"gps": BERNOULLI, "wheel": BERNOULLI}}


def test_defaults() -> None:
    o = options(body())
    assert (o.tolerance, o.horizon, o.grid) == (1e-6, 8, None)
    assert o.packets[0].name is None and o.packets[0].rows == (0,)


@pytest.mark.parametrize(
    "bounds,field,match",
    [
        ({"tolerence": 1e-6}, "/options/bounds/tolerence", "unknown option"),
        ({"tolerance": 1e-12}, "/options/bounds/tolerance", r"\[1e-09, 0.1\]"),
        ({"tolerance": 0.5}, "/options/bounds/tolerance", "must lie in"),
        ({"tolerance": True}, "/options/bounds/tolerance", "must be a number"),
        ({"horizon": 0}, "/options/bounds/horizon", "at least 1"),
        ({"horizon": 21}, "/options/bounds/horizon", "exceeds the limit 20"),
        ({"horizon": 2.5}, "/options/bounds/horizon", "integer"),
        ({"horizon": "8"}, "/options/bounds/horizon", "integer"),
        ({"grid": 5}, "/options/bounds/grid", "exactly two sensors"),
        ({"arrival_probability": 1.5}, "/options/bounds/arrival_probability", r"\[0, 1\]"),
        ({"arrival_probability": -0.1}, "/options/bounds/arrival_probability", r"\[0, 1\]"),
        ({"arrival_probability": {"gps": 0.5}}, "/options/bounds/arrival_probability", "a number"),
    ],
)
def test_bad_options_name_their_field(bounds, field, match) -> None:
    with pytest.raises(InvalidInput, match=match) as err:
        options(body(bounds=bounds))
    assert err.value.field == field


def test_horizon_limit_shrinks_with_the_state_dimension() -> None:
    n = 10
    system = {
        "A": [[1 if i == j else 0 for j in range(n)] for i in range(n)],
        "C": [[1] * n],
        "Q": [[1 if i == j else 0 for j in range(n)] for i in range(n)],
        "R": [[1]],
    }
    assert options(body(system=system)).horizon == 8
    assert options(body(system=system, bounds={"horizon": 15})).horizon == 15
    with pytest.raises(LimitExceeded, match="limit 15 for 10 states") as err:
        options(body(system=system, bounds={"horizon": 16}))
    assert err.value.field == "/options/bounds/horizon"


@pytest.mark.parametrize(
    "bounds,field,error",
    [
        ({"grid": 42}, "/options/bounds/grid", LimitExceeded),
        ({"grid": 1}, "/options/bounds/grid", LimitExceeded),
        ({"horizon": 4}, "/options/bounds/horizon", InvalidInput),
        ({"arrival_probability": 0.5}, "/options/bounds/arrival_probability", InvalidInput),
        ({"arrival_probability": {"gsp": 0.5}}, "/options/bounds/arrival_probability/gsp", InvalidInput),
        ({"arrival_probability": {"gps": 2}}, "/options/bounds/arrival_probability/gps", InvalidInput),
    ],
)
def test_bad_two_sensor_options(bounds, field, error) -> None:
    with pytest.raises(error) as err:
        options(body(system=two_sensor_system(), channel=PER_SENSOR, bounds=bounds))
    assert err.value.field == field


def test_two_sensor_options_and_overrides() -> None:
    o = options(
        body(
            system=two_sensor_system(), channel=PER_SENSOR, bounds={"grid": 41, "arrival_probability": {"wheel": "1/3"}}
        )
    )
    assert o.grid == 41 and o.horizon is None
    assert [p.name for p in o.packets] == ["gps", "wheel"] and [str(x) for x in o.arrival] == ["2/5", "1/3"]


def test_flags_override_the_request_and_say_so() -> None:
    o = options(body(bounds={"horizon": 2, "tolerance": 1e-3}), {"horizon": 4})
    assert o.horizon == 4 and o.tolerance == 1e-3
    with pytest.raises(LimitExceeded, match=r"given as --horizon") as err:
        options(body(), {"horizon": 99})
    assert err.value.field == "/options/bounds/horizon"


@pytest.mark.parametrize("missing", ["Q", "R"])
def test_noise_covariances_are_required(missing) -> None:
    system = {k: v for k, v in SYSTEM.items() if k != missing}
    with pytest.raises(InvalidInput, match=f"covariance {missing}") as err:
        compute_bounds(load_request(json.dumps(body(system=system))))
    assert err.value.field == f"/system/{missing}"


def test_gilbert_elliott_is_rejected_with_the_reason() -> None:
    ge = {"model": "gilbert_elliott", "failure_rate": 0.2, "recovery_rate": 0.5}
    with pytest.raises(InvalidInput, match="i.i.d.") as err:
        options(body(channel=ge))
    assert err.value.field == "/channel/model"
    per = {"model": "per_sensor", "channels": {"gps": BERNOULLI, "wheel": ge}}
    with pytest.raises(InvalidInput, match="gilbert_elliott channel has memory") as err:
        options(body(system=two_sensor_system(), channel=per))
    assert err.value.field == "/channel/channels/wheel/model"


def test_memoryless_channels_in_disguise_are_accepted() -> None:
    # Gilbert-Elliott with p + q = 1 and Markov of order 0 are i.i.d.: the Bernoulli bounds apply.
    ge = {"model": "gilbert_elliott", "failure_rate": 0.6, "recovery_rate": 0.4}
    assert str(options(body(channel=ge)).arrival[0]) == "2/5"
    mk = {"model": "markov", "order": 0, "arrival_probability": {"": "0.3"}}
    assert str(options(body(channel=mk)).arrival[0]) == "3/10"


def test_lmi_size_limit() -> None:
    n = 10
    eye = [[1 if i == j else 0 for j in range(n)] for i in range(n)]
    system = {
        "A": eye,
        "C": eye,
        "Q": eye,
        "R": eye,
        "sensors": [{"name": f"s{i}", "rows": [2 * i, 2 * i + 1]} for i in range(5)],
    }
    channel = {"model": "per_sensor", "channels": {f"s{i}": BERNOULLI for i in range(5)}}
    with pytest.raises(LimitExceeded, match=r"n\(2\^m \+ 1\) = 330") as err:
        options(body(system=system, channel=channel))
    assert err.value.field == "/system/sensors"


def test_probability_bounds_are_legal() -> None:
    for lam in (0, 1, "0", "1/1"):
        options(body(channel={"model": "bernoulli", "arrival_probability": lam}))
