"""Edges of the exact number grammar (mutants of bench/mutation.py): floats mean their decimal text, and the exponent limit.

A Python float is read through its shortest ``repr``: ``0.1`` is exactly ``1/10``,
never the binary double ``3602879701896397/36028797018963968``.  The exponent of
a decimal must lie in ``[-4 D, 4 D]`` for ``D`` digits per number (``[-800, 800]``
by default): the edge itself is accepted and one past it refused, for both signs.
"""

from __future__ import annotations

from decimal import Decimal
from fractions import Fraction

import numpy as np
import pytest

import kfio
from kfio.errors import LimitExceeded
from kfio.model._exact import parse_number
from kfio.model._limits import DEFAULT_LIMITS

EDGE = 4 * DEFAULT_LIMITS.max_digits


def test_the_edge_is_800_by_default() -> None:
    assert EDGE == 800


@pytest.mark.parametrize(
    ("value", "exact"),
    [
        (0.1, Fraction(1, 10)),
        (-0.1, Fraction(-1, 10)),
        (1.1, Fraction(11, 10)),
        (0.3, Fraction(3, 10)),
        (1e-7, Fraction(1, 10**7)),
        (np.float64(0.1), Fraction(1, 10)),
        (2.5, Fraction(5, 2)),  # a dyadic float: text and binary value agree
    ],
)
def test_a_float_is_its_shortest_decimal_text(value, exact) -> None:
    got = parse_number(value, "/x")
    assert got == exact and type(got) is Fraction
    if value != 2.5:
        assert got != Fraction(float(value))  # the binary double is a different number


def test_the_python_api_reads_0_1_as_one_tenth() -> None:
    s = kfio.System(A=[[0.1]], C=[[1]])
    assert s.A[0][0] == Fraction(1, 10)


def _body(number_text: str) -> str:
    channel = '"channel": {"model": "bernoulli", "arrival_probability": 0.5}'
    return '{"system": {"A": [[' + number_text + ']], "C": [[1]]}, ' + channel + "}"


def _at(exponent: int) -> list[tuple[str, Fraction]]:
    """Decimals written with exactly this exponent, and their values."""
    forms = [(f"0e{exponent}", Fraction(0))]
    if exponent > 0:  # 10^-exponent written out, times 10^exponent: exactly 1, with few significant digits
        forms.append(("0." + "0" * (exponent - 1) + f"1e{exponent}", Fraction(1)))
    return forms


@pytest.mark.parametrize("sign", [1, -1])
def test_an_exponent_at_the_limit_is_accepted(sign: int) -> None:
    for text, value in _at(sign * EDGE):
        assert parse_number(text, "/x") == value
    # a JSON number reaches parse_number as a Decimal (load_json), with its exponent
    assert parse_number(Decimal(f"0e{sign * EDGE}"), "/x") == 0
    assert kfio.load_request(_body(f"0e{sign * EDGE}")).system.A[0][0] == 0


@pytest.mark.parametrize("sign", [1, -1])
def test_an_exponent_one_past_the_limit_is_refused(sign: int) -> None:
    rule = rf"the exponent of a number must lie in \[-{EDGE}, {EDGE}\]$"
    for text, _ in _at(sign * (EDGE + 1)):
        with pytest.raises(LimitExceeded, match="^/x: " + rule):
            parse_number(text, "/x")
    with pytest.raises(LimitExceeded, match="^/x: " + rule):
        parse_number(Decimal(f"0e{sign * (EDGE + 1)}"), "/x")
    with pytest.raises(LimitExceeded, match="^/system/A/0/0: " + rule):
        kfio.load_request(_body(f"0e{sign * (EDGE + 1)}"))
