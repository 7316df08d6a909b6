"""The number grammar is ASCII and every limit is checked from the text.

Reproducers: ``"options": {"bounds": {"horizon": 1e999999999}}`` hung the CLI;
``"\\u0661.\\u0662\\u0665"`` (Arabic-Indic digits) parsed as 5/4; vertical tab and
form feed were accepted as whitespace; messages showed ``Decimal('1E+999999')``.
"""

from __future__ import annotations

import json
from decimal import Decimal
from fractions import Fraction

import pytest

from kfio import load_request
from kfio.errors import InvalidInput, LimitExceeded
from kfio.model._exact import load_json, parse_integer, parse_number, value_text
from kfio.riccati_bounds._options import parse_bounds_options
from kfio.simulation._setup import parse_options as parse_simulate_options

BASE = {
    "system": {"A": [[2]], "C": [[1]], "Q": [[1]], "R": [[1]]},
    "channel": {"model": "bernoulli", "arrival_probability": "0.9"},
}


def _request(options_text: str):
    body = json.dumps(BASE)[:-1] + f', "options": {options_text}}}'
    return load_request(body)


@pytest.mark.parametrize(
    "text",
    [
        "\u0661.\u0662\u0665",  # Arabic-Indic digits
        "\uff11\uff12",  # full-width digits
        "1\u00b2",  # superscript two: str.isdigit() is True
        "\u0967/2",  # Devanagari one
        "1\x0b",  # vertical tab
        "\x0c1/2",  # form feed
        "1/\u00a02",  # no-break space
        "1\u2003",  # em space
    ],
)
def test_non_ascii_digits_and_whitespace_are_refused(text: str) -> None:
    with pytest.raises(InvalidInput, match="is not a number") as err:
        parse_number(text, "/x")
    assert err.value.rule.isascii()


@pytest.mark.parametrize(
    ("text", "value"),
    [("11/10", Fraction(11, 10)), ("-3/4", Fraction(-3, 4)), ("1.5e-3/2.5", Fraction(3, 5000)), ("+.5E+1", 5)],
)
def test_ascii_grammar_still_reads_the_documented_forms(text: str, value: Fraction) -> None:
    assert parse_number(text, "/x") == value


@pytest.mark.parametrize("exponent", ["9" * 30, "9" * 5000, "-" + "9" * 30])
def test_json_exponents_beyond_decimal_range_are_a_limit(exponent: str) -> None:
    # decimal.Decimal refuses exponents above 10^18 with InvalidOperation (outside our hierarchy)
    tree = load_json(f'{{"x": 1e{exponent}}}')
    with pytest.raises(LimitExceeded, match=r"^/x: the exponent of a number must lie in \[-800, 800\]$"):
        parse_number(tree["x"], "/x")


def test_long_exponent_in_a_string_is_a_limit_not_a_huge_message() -> None:
    with pytest.raises(LimitExceeded) as err:
        parse_number("1e" + "9" * 700, "/x")
    assert len(str(err.value)) < 100


BOMBS = ["1e999999999", "1e99999999999999999999", "-1e999999999", "1.5e999999999"]


@pytest.mark.parametrize("bomb", BOMBS)
@pytest.mark.parametrize("key", ["horizon", "grid"])
def test_bounds_integer_options_are_range_checked_before_conversion(key: str, bomb: str) -> None:
    req = _request(f'{{"bounds": {{"{key}": {bomb}}}}}')
    with pytest.raises(InvalidInput, match=rf"^/options/bounds/{key}: {key} must be") as err:
        parse_bounds_options(req)
    assert "Decimal" not in str(err.value)


@pytest.mark.parametrize("bomb", BOMBS)
@pytest.mark.parametrize("key", ["steps", "trajectories", "seed", "exact_steps"])
def test_simulate_integer_options_are_range_checked_before_conversion(key: str, bomb: str) -> None:
    req = _request(f'{{"simulate": {{"{key}": {bomb}}}}}')
    with pytest.raises(InvalidInput, match=rf"^/options/simulate/{key}: {key} must") as err:
        parse_simulate_options(req)
    assert "Decimal" not in str(err.value)


@pytest.mark.parametrize("bomb", ["1e999999999", "1e-999999999", "1e99999999999999999999"])
def test_time_budget_bomb(bomb: str) -> None:
    with pytest.raises(InvalidInput, match="^/options/time_budget_s: "):
        _request(f'{{"time_budget_s": {bomb}}}')


def test_integral_decimals_are_integers_and_fractions_are_not() -> None:
    assert parse_simulate_options(_request('{"simulate": {"steps": 1e2, "trajectories": 20.0}}')).steps == 100
    with pytest.raises(InvalidInput, match="steps must be an integer; got 10.5"):
        parse_simulate_options(_request('{"simulate": {"steps": 10.5}}'))
    with pytest.raises(InvalidInput, match='seed must be an integer; got "7"'):
        parse_simulate_options(_request('{"simulate": {"seed": "7"}}'))


def test_unbounded_integer_options_have_a_digit_limit() -> None:
    with pytest.raises(LimitExceeded, match="at most 30 digits"):
        parse_integer(Decimal("1e40"), "/x", 0, None, "trajectories")


def test_messages_show_json_text_not_python_reprs() -> None:
    with pytest.raises(InvalidInput) as err:
        load_request(json.dumps({**BASE, "channel": {"model": 1e999999}}).replace("Infinity", "1E+999999"))
    assert "Decimal" not in str(err.value) and "1e999999" in str(err.value)
    assert value_text(Decimal("1E+999999")) == "1e999999"
    assert value_text("\ud800") == '"\\ud800"'
    assert value_text(10**100) == "an integer of more than 40 digits"
