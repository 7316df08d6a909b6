"""What a number in a string is, and what an error may quote.

A string holds a number and nothing else: ``" 1"`` is not a number, ``"-0"``
is zero.  A decimal's written exponent may reach ``+-4 D`` (``D`` digits per
number), but its exact value must still fit ``D`` digits in numerator and
denominator: ``1e-300`` is ``1/10^300``, refused for that reason, not for
having "too many digits" in its text.  Every client value an error quotes is
cut to :data:`kfio.errors.ECHO_LIMIT` characters, and error fields and rules
are bounded whatever the request held.
"""

from __future__ import annotations

import json
from decimal import Decimal
from fractions import Fraction
from pathlib import Path

import pytest

import kfio
from kfio.errors import ECHO_LIMIT, FIELD_LIMIT, RULE_LIMIT, InvalidInput, LimitExceeded, clip, clip_pointer
from kfio.model import WITHHELD_TEXT, json_pointer, load_json, parse_number, value_text, values_withheld
from kfio.model._limits import DEFAULT_LIMITS

D = DEFAULT_LIMITS.max_digits
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _request(a_text: str) -> str:
    channel = '"channel": {"model": "bernoulli", "arrival_probability": 0.5}'
    return '{"system": {"A": [[' + a_text + ']], "C": [[1]]}, ' + channel + "}"


@pytest.mark.parametrize("text", [" 1", "1 ", "\t1", "1\n", " 11/10", "11 /10", "11/ 10", "11/10 ", "- 1", "1 e3"])
def test_whitespace_in_a_number_string_is_not_a_number(text: str) -> None:
    with pytest.raises(InvalidInput, match=r"is not a number \(.*with no spaces\)$") as err:
        parse_number(text, "/x")
    assert type(err.value) is InvalidInput  # not a limit: the text is outside the grammar
    with pytest.raises(InvalidInput, match=r"^/system/A/0/0: .* is not a number"):
        kfio.load_request(_request(json.dumps(text)))


def test_whitespace_around_a_json_number_is_json_whitespace() -> None:
    assert kfio.load_request(_request(" 1.5 ")).system.A[0][0] == Fraction(3, 2)


@pytest.mark.parametrize("text", ["-0", "-0.0", "+0", "-0e5", "-0/7", "0/-3"])
def test_minus_zero_is_zero(text: str) -> None:
    got = parse_number(text, "/x")
    assert got == 0 and type(got) is Fraction
    assert kfio.load_request(_request(json.dumps(text))).system.A[0][0] == 0


def test_json_minus_zero_is_zero() -> None:
    assert kfio.load_request(_request("-0")).system.A[0][0] == 0
    assert kfio.load_request(_request("-0.0")).system.A[0][0] == 0


def _digits(x: Fraction) -> tuple[int, int]:
    return len(str(abs(x.numerator))), len(str(x.denominator))


@pytest.mark.parametrize("k", [D - 1, D, D + 1, 300, 4 * D])
@pytest.mark.parametrize("sign", [1, -1])
def test_a_far_exponent_is_judged_by_the_exact_value(k: int, sign: int) -> None:
    """``1e(-k)`` is ``1/10^k``: its denominator has ``k + 1`` digits; accepted iff that is at most ``D``."""
    text = f"1e{sign * k}"
    exact = Fraction(10) ** (sign * k)  # the value, built independently of the parser
    part = "denominator" if sign < 0 else "numerator"
    if max(_digits(exact)) <= D:
        assert parse_number(text, "/x") == exact
        assert parse_number(Decimal(text), "/x") == exact
        return
    for value in (text, Decimal(text)):
        with pytest.raises(LimitExceeded) as err:
            parse_number(value, "/x")
        rule = err.value.rule
        assert f"has {k + 1} digits in its {part}" in rule and f"at most {D} digits each" in rule
        assert "exponent" in rule and "numbers may have at most" not in rule  # not the significant-digits rule


def test_1e_minus_300_names_its_denominator_not_its_digits() -> None:
    with pytest.raises(LimitExceeded, match=r"^/system/A/0/0: the exact value of this number has 301 digits in its "):
        kfio.load_request(_request("1e-300"))
    with pytest.raises(LimitExceeded, match=r"has 301 digits in its denominator"):
        kfio.load_request(_request('"1e-300"'))


def test_many_significant_digits_keep_their_own_rule() -> None:
    with pytest.raises(LimitExceeded, match=rf"^/x: numbers may have at most {D} digits$"):
        parse_number("1" * (D + 1), "/x")
    assert parse_number("0." + "0" * 150 + "1" + "e100", "/x") == Fraction(1, 10**51)


def test_clip_keeps_short_text_and_cuts_long_text() -> None:
    assert clip("a" * ECHO_LIMIT) == "a" * ECHO_LIMIT
    assert clip("a" * (ECHO_LIMIT + 1)) == "a" * ECHO_LIMIT + "..."
    assert value_text("s" * 10_000) == '"' + "s" * 36 + "..."
    assert len(value_text("s" * 10_000, 1000)) <= ECHO_LIMIT + 3


def test_clip_pointer_bounds_each_token_and_the_whole() -> None:
    key = "k" * 1_000_000
    p = clip_pointer(json_pointer(["system", key, "x"]))
    assert p == "/system/" + "k" * ECHO_LIMIT + ".../x"
    deep = clip_pointer(json_pointer(["a" * 200] * 50))
    assert len(deep) <= FIELD_LIMIT + 5 and deep.startswith("/aaa") and "/.../" in deep
    # a cut never leaves half of an RFC 6901 escape behind
    tilde = clip_pointer("/" + "b" * (ECHO_LIMIT - 1) + "~1" + "c" * 50)
    assert tilde == "/" + "b" * (ECHO_LIMIT - 1) + "..."
    assert clip_pointer("/system/A/0/1") == "/system/A/0/1"


def test_every_invalid_input_is_bounded() -> None:
    exc = InvalidInput("/options/" + "k" * 1_000_000, "rule " + "r" * 1_000_000)
    assert len(exc.field) <= FIELD_LIMIT + 5 and len(exc.rule) <= RULE_LIMIT + 3 and len(str(exc)) < 4 * RULE_LIMIT


def test_a_megabyte_unknown_key_gives_a_small_error() -> None:
    body = _request("2")[:-1] + ', "options": {"' + "k" * 1_000_000 + '": 1}}'
    with pytest.raises(InvalidInput) as err:
        kfio.load_request(body)
    assert err.value.field.startswith("/options/kkkk") and len(str(err.value)) < 1000


def test_a_megabyte_loop_protocol_is_quoted_short() -> None:
    from kfio.loop import parse_loop_request

    tree = load_json((EXAMPLES / "loop_scalar.json").read_bytes())
    tree.setdefault("options", {})["loop"] = {"protocol": "p" * 1_000_000}
    with pytest.raises(InvalidInput) as err:
        parse_loop_request(tree)
    assert err.value.field == "/options/loop/protocol"
    assert "p" * (ECHO_LIMIT + 1) not in err.value.rule and len(err.value.rule) < 200


def test_values_withheld_hides_strings_numbers_and_keys_quoted_by_value_text() -> None:
    with values_withheld():
        assert value_text("ghp_SECRETTOKEN123") == WITHHELD_TEXT
        assert value_text(Decimal("123456")) == WITHHELD_TEXT
        with pytest.raises(InvalidInput) as err:
            parse_number("ghp_SECRETTOKEN123", "/x")
    assert "SECRET" not in str(err.value) and WITHHELD_TEXT in err.value.rule
    assert value_text("x") == '"x"'  # only inside the block
