"""Bad arguments to the Python API: the JSON route's rule, with the Python argument as the field."""

from __future__ import annotations

from decimal import Decimal

import control
import numpy as np
import pytest

import kfio
from kfio import AssumptionViolation, InvalidInput, LimitExceeded, parse_request


def json_rule(system: dict, channel: dict | None = None, options: dict | None = None) -> tuple[str, str, type]:
    """``(field, rule, class)`` of the validator's error on a request tree (what load_json would hand it)."""
    tree = {"system": system, "channel": channel or {"model": "bernoulli", "arrival_probability": "1/2"}}
    if options is not None:
        tree["options"] = options
    with pytest.raises(InvalidInput) as info:
        parse_request(tree)
    return info.value.field, info.value.rule, type(info.value)


@pytest.mark.parametrize(
    "value, tree_value",
    [
        (2j, 2j),
        (np.complex128(1 + 1j), np.complex128(1 + 1j)),
        (True, True),
        (np.bool_(False), False),
        (float("nan"), Decimal("NaN")),
        (np.float32("inf"), Decimal("Infinity")),
        (-np.inf, Decimal("-Infinity")),
        (None, None),
        ("1/0", "1/0"),
        ("x", "x"),
    ],
)
def test_bad_entries_name_the_argument_with_the_json_rule(value, tree_value):
    with pytest.raises(InvalidInput) as info:
        kfio.System(A=[[1, value], [0, 1]], C=[[1, 0]])
    field, rule, _ = json_rule({"A": [[1, tree_value], [0, 1]], "C": [[1, 0]]})
    assert (info.value.field, info.value.rule) == ("A[0][1]", rule) and field == "/system/A/0/1"
    assert str(info.value).startswith("A[0][1]: ")


def test_whole_arrays_of_complex_or_nan_are_refused_at_their_first_entry():
    with pytest.raises(InvalidInput, match=r"^C\[0\]\[0\]: expected a number, got a complex128$"):
        kfio.System(A=np.eye(2), C=np.array([[1, 0]], dtype=complex))
    with pytest.raises(InvalidInput, match=r"^Q\[1\]\[1\]: NaN and infinities are not numbers$"):
        kfio.System(A=np.eye(2), C=[[1, 0]], Q=np.diag([1.0, np.nan]))


@pytest.mark.parametrize(
    "kwargs, field, tree",
    [
        (dict(A=[[1, 2]], C=[[1, 0]]), "A", {"A": [[1, 2]], "C": [[1, 0]]}),
        (dict(A=np.eye(2), C=[[1]]), "C", {"A": [[1, 0], [0, 1]], "C": [[1]]}),
        (dict(A=np.eye(2), C=[1, 0]), "C[0]", {"A": [[1, 0], [0, 1]], "C": [1, 0]}),
        (dict(A=np.ones((0, 0)), C=[[1]]), "A", {"A": [], "C": [[1]]}),
        (dict(A=[[1]], C=[[1]], R=[[0]]), "R", {"A": [[1]], "C": [[1]], "R": [[0]]}),
        (dict(A=[[1]], C=[[1]], Q=[[-1]]), "Q", {"A": [[1]], "C": [[1]], "Q": [[-1]]}),
        (
            dict(A=np.eye(2), C=np.eye(2), Q=[[1, 2], [3, 4]]),
            "Q[0][1]",
            {"A": [[1, 0], [0, 1]], "C": [[1, 0], [0, 1]], "Q": [[1, 2], [3, 4]]},
        ),
    ],
)
def test_shape_and_definiteness_rules_name_the_matrix(kwargs, field, tree):
    with pytest.raises(InvalidInput) as info:
        kfio.System(**kwargs)
    _, rule, kind = json_rule(tree)
    assert info.value.field == field and info.value.rule == rule and type(info.value) is kind


def test_too_large_is_a_limit():
    with pytest.raises(LimitExceeded, match=r"^A: A has 121 rows; the limit is 120$"):
        kfio.System(A=np.eye(121), C=np.ones((1, 121)))
    big = kfio.System(A=np.eye(41), C=np.ones((1, 41)))  # as large as analyze accepts; bounds takes 40
    with pytest.raises(LimitExceeded, match=r"^system.A: A has 41 rows; the limit is 40 \(kfio analyze accepts"):
        kfio.bounds(big, kfio.bernoulli(0.5))


def test_a_system_built_with_larger_limits_is_analyzed_with_them():
    huge = "1" + "0" * 299 + "/" + "3" * 300  # 300 digits, beyond the default 200
    with pytest.raises(LimitExceeded, match=r"^A\[0\]\[0\]: numbers may have at most 200 digits$"):
        kfio.System(A=[[huge]], C=[[1]])
    system = kfio.System(A=[[huge]], C=[[1]], limits=kfio.Limits(max_digits=400))
    assert kfio.analyze(system, kfio.bernoulli(0.5)).verdict == "stable"  # |a| = 0.3..., below 1


def test_sensor_errors_name_the_sensor_as_written():
    with pytest.raises(InvalidInput, match=r"^sensors\['b'\]\[0\]: row 0 of C is already carried by sensor 'a'"):
        kfio.System(A=np.eye(2), C=np.eye(2), sensors={"a": [0], "b": [0]})
    with pytest.raises(InvalidInput, match=r"^sensors: sensors must partition the rows of C; rows \[1\]"):
        kfio.System(A=np.eye(2), C=np.eye(2), sensors={"a": [0]})
    with pytest.raises(InvalidInput, match=r"^sensors\[0\]\['rows'\]\[0\]: a row index must be an integer in \[0, 1\]"):
        kfio.System(A=np.eye(2), C=np.eye(2), sensors=[{"name": "a", "rows": [2]}, {"name": "b", "rows": [1]}])


def test_channel_errors_name_the_channel_argument():
    with pytest.raises(InvalidInput, match=r"^p: a probability must lie in \[0, 1\]; got 1.5$"):
        kfio.bernoulli(1.5)
    with pytest.raises(InvalidInput, match=r"^recovery_rate: expected a number, got a complex$"):
        kfio.gilbert_elliott(failure_rate=0.1, recovery_rate=1j)
    with pytest.raises(InvalidInput, match=r"^arrival_probability: missing histories: '1'"):
        kfio.markov({"0": 0.5})
    with pytest.raises(InvalidInput, match=r"^channels\['gps'\]\['arrival_probability'\]: a probability must lie"):
        kfio.per_sensor({"gps": 2})
    system = kfio.System(A=np.eye(2) * 2, C=np.eye(2), sensors={"gps": [0], "imu": [1]})
    with pytest.raises(InvalidInput, match=r"^channel\['imu'\]: sensor 'imu' has no channel$"):
        kfio.analyze(system, kfio.per_sensor({"gps": 0.5}))
    with pytest.raises(InvalidInput, match=r"^channel\['model'\]: with several sensors the channel must be"):
        kfio.analyze(system, kfio.bernoulli(0.5))
    with pytest.raises(InvalidInput, match=r"^channel: a channel is required"):
        kfio.analyze(system)
    with pytest.raises(InvalidInput, match=r"^channel: expected a channel: kfio.bernoulli\(p\), .*; got a float$"):
        kfio.analyze(system, 0.5)
    with pytest.raises(
        InvalidInput, match=r"^system: expected a kfio.System or a discrete-time python-control StateSpace; got a list$"
    ):
        kfio.analyze([[2]], kfio.bernoulli(0.5))


def test_assumption_1_names_the_channel_field():
    with pytest.raises(AssumptionViolation, match=r"^channel\['arrival_probability'\]: Assumption 1"):
        kfio.analyze(kfio.System(A=[[2]], C=[[1]]), kfio.bernoulli(1))
    # bounds and simulation allow it, as the JSON route does
    assert kfio.bounds(kfio.System(A=[[2]], C=[[1]], Q=[[1]], R=[[1]]), kfio.bernoulli(1)).verdict == "stable"


def test_option_and_budget_errors_name_the_keyword():
    sys = kfio.System(A=[[1.2]], C=[[1]], Q=[[1]], R=[[1]])
    ch = kfio.bernoulli(0.5)
    with pytest.raises(InvalidInput, match=r"^steps: steps must be at least 1; got 0$"):
        kfio.simulate(sys, ch, steps=0)
    with pytest.raises(InvalidInput, match=r"^options\['stepz'\]: unknown option 'stepz'"):
        kfio.simulate(sys, ch, options={"stepz": 3})
    with pytest.raises(
        InvalidInput, match=r"^options\['x'\]: unknown option 'x'; allowed: critical_parameter, ge_grid$"
    ):
        kfio.analyze(sys, ch, options={"x": 1})
    with pytest.raises(InvalidInput, match=r"^budget: time_budget_s must be in \[0.01, 3600\] seconds$"):
        kfio.analyze(sys, ch, budget=-1.0)
    with pytest.raises(InvalidInput, match=r"^steps: the horizon must be a non-negative integer; got -1$"):
        kfio.expected_covariance(sys, ch, -1)
    with pytest.raises(InvalidInput, match=r"^P0: P0 must be positive semidefinite$"):
        kfio.expected_covariance(sys, ch, 2, P0=[[-1]])
    with pytest.raises(InvalidInput, match=r"^system\.Q: the bounds need the process noise covariance Q$"):
        kfio.bounds(kfio.System(A=[[2]], C=[[1]]), ch)


def test_from_statespace_refuses_continuous_time_and_other_objects():
    with pytest.raises(InvalidInput, match=r"^ss: the StateSpace is continuous-time \(dt=0\).*control\.c2d"):
        kfio.System.from_statespace(control.ss([[0, 1], [-1, 0]], [[0], [1]], [[1, 0]], [[0]]))
    with pytest.raises(InvalidInput, match=r"^ss: the StateSpace has an unspecified time base \(dt=None\)"):
        kfio.System.from_statespace(control.ss([[1]], [[1]], [[1]], [[0]], None))
    with pytest.raises(InvalidInput, match=r"^ss: expected a python-control StateSpace; got a TransferFunction"):
        kfio.System.from_statespace(control.tf([1], [1, 2], 0.1))
    with pytest.raises(InvalidInput, match=r"^R: R must be positive definite$"):
        kfio.System.from_statespace(control.ss([[1]], [[1]], [[1]], [[0]], 0.1), R=[[0]])


def test_the_json_route_reads_numpy_float64_through_its_value_text():
    # the issue: repr(np.float64(0.5)) is "np.float64(0.5)" under numpy 2
    assert kfio.parse_number(np.float64(0.5), "/x") == kfio.parse_number("0.5", "/x")
    tree = {
        "system": {"A": [[np.float64(1.1)]], "C": [[1]]},
        "channel": {"model": "bernoulli", "arrival_probability": 0.5},
    }
    assert parse_request(tree).system.A == ((kfio.parse_number("1.1", "/x"),),)
