"""The option table (kfio.model.OPTION_FIELDS) is what the validator enforces and what the schemas publish.

Every numeric option is probed through the real validator at both ends of its
table range (inside accepted, a value just outside refused, naming the
field); every enum value is accepted and another word refused; the option
names each validator allows are exactly the table's; and the shipped JSON
Schemas state the same ranges, enums and size limits.
"""

from __future__ import annotations

import dataclasses
import json
import re
from fractions import Fraction
from typing import Any

import pytest

from kfio import load_request
from kfio.errors import InvalidInput
from kfio.loop import load_loop_request
from kfio.model import (
    DEFAULT_LIMITS,
    MAX_CHECK_ENTRIES,
    MAX_NUMBER_TEXT,
    MAX_RUN_BUDGET_S,
    OPTION_FIELDS,
    OPTION_GROUP_NAMES,
    OPTION_KEYS,
    REQUEST_GROUPS,
    OptionField,
    option_fields,
)
from kfio.riccati_bounds._phat import max_horizon
from kfio.sweep import parse_sweep

from support.option_requests import BASES as OPTION_BASES
from support.option_requests import NEEDS, VALIDATORS
from support.paths import ROOT

BASES: dict[str, dict[str, Any]] = {
    **OPTION_BASES,
    "loop": {
        "system": {"A": [[1.25]], "B": [[1]], "C": [[1]], "Q": [[1]], "R": [[0.5]]},
        "channel": {"model": "bernoulli", "arrival_probability": 0.8},
        "actuator_channel": {"model": "bernoulli", "arrival_probability": 0.9},
        "controller": {"gains": {"feedback": [[0.6]], "estimator": [[0.5]]}},
    },
}
#: What the rest of an object-valued option must hold while one of its keys is probed.
OBJECT_REST: dict[str, dict[str, Any]] = {"simulate.outage_target": {"threshold": 1, "epsilon": "1/2"}}


def _validate(group: str, options: dict[str, Any], base: str = "one") -> None:
    """Run the validator of ``group`` (``""``: the top-level options) on a request carrying ``options``."""
    if group == "sweep":  # the sweep file's own options, beside its base request
        parse_sweep({"command": "analyze", "base": BASES["one"], "axes": [], "options": options["sweep"]})
        return
    if group == "loop" or (group == "" and base == "loop"):
        load_loop_request(json.dumps(dict(BASES["loop"], options=options)))
        return
    r = load_request(json.dumps(dict(BASES[base], options=options)))
    if group:
        VALIDATORS[group](r)


def _options(field: OptionField, value: Any) -> dict[str, Any]:
    top, _, sub = field.group.partition(".")
    if sub:  # a key of an object-valued option
        return {top: {sub: {**OBJECT_REST[field.group], field.name: value}}}
    if not top:
        return {field.name: value}
    return {top: {field.name: [value] if field.kind == "number_list" else value}}


def _check(field: OptionField, value: Any, accepted: bool, base: str) -> None:
    group = field.group.partition(".")[0]
    try:
        _validate(group, _options(field, value), base)
    except InvalidInput as exc:
        assert not accepted, f"{field.pointer} = {value!r} refused: {exc}"
        assert exc.field.startswith(field.pointer), (field.pointer, exc.field)
    else:
        assert accepted, f"{field.pointer} = {value!r} accepted, outside the table's range"


def _all_fields() -> list[OptionField]:
    return [p for f in OPTION_FIELDS for p in (f, *f.properties)]


def _bases(field: OptionField) -> list[str]:
    key = f"{field.group}.{field.name}" if field.group else field.name
    if field.group in ("loop", "sweep"):
        return [field.group]
    if field.group == "":  # the top-level options: the request parser and the loop's
        return ["one", "loop"]
    return [NEEDS.get(key, "one")]


def _probes(field: OptionField) -> list[tuple[Any, bool]]:
    """``(value, accepted?)`` at both ends of ``field``'s range; numbers as exact fraction text."""
    out: list[tuple[Any, bool]] = []
    if field.kind == "integer":
        for end, step in ((field.minimum, -1), (field.maximum, 1)):
            if end is not None:
                out += [(int(end), True), (int(end) + step, False)]
        return out
    for end, step, exclusive in (
        (field.minimum, -1, field.exclusive_minimum),
        (field.maximum, 1, field.exclusive_maximum),
    ):
        if end is None:
            continue
        eps = Fraction(end or 1) / 10**6 if end else Fraction(1, 10**6)
        eps = abs(eps)
        inside, outside = (end - step * eps, end) if exclusive else (end, end + step * eps)
        out += [(str(Fraction(inside)), True), (str(Fraction(outside)), False)]
    return out


RANGED = [(f, base) for f in _all_fields() if f.kind in ("integer", "number", "number_list") for base in _bases(f)]


@pytest.mark.parametrize(("field", "base"), RANGED, ids=[f"{f.pointer}-{b}" for f, b in RANGED])
def test_each_end_of_a_table_range_is_the_validators(field: OptionField, base: str) -> None:
    probes = _probes(field)
    assert probes, field  # every numeric option has at least one stated end
    for value, accepted in probes:
        _check(field, value, accepted, base)


ENUMS = [f for f in _all_fields() if f.kind == "enum"]


@pytest.mark.parametrize("field", ENUMS, ids=[f.pointer for f in ENUMS])
def test_every_enum_value_is_accepted_and_no_other(field: OptionField) -> None:
    base = _bases(field)[0]
    for value in field.enum:
        _check(field, value, True, base)
    _check(field, "no_such_value", False, base)
    assert field.default in field.enum


def test_the_fixed_percentiles_are_the_only_value() -> None:
    (field,) = [f for f in OPTION_FIELDS if f.kind == "fixed"]
    _check(field, list(field.default), True, "one")
    _check(field, [50, 90], False, "one")


def _allowed_by_refusal(group: str) -> set[str]:
    """The keys the validator of ``group`` allows, from its own refusal of an unknown key."""
    if group == "loop":
        options: dict[str, Any] = {"loop": {"no_such_option": 1}}
    elif group == "":
        options = {"no_such_option": 1}
    else:
        r = dataclasses.replace(load_request(json.dumps(BASES["one"])), options={group: {"no_such_option": 1}})
        with pytest.raises(InvalidInput) as by_command:
            VALIDATORS[group](r)
        assert by_command.value.field == f"/options/{group}/no_such_option"
        options = {group: {"no_such_option": 1}}
    with pytest.raises(InvalidInput) as err:
        _validate("loop" if group == "loop" else "", options)
    m = re.search(r"allowed: (.*)$", err.value.rule)
    assert m is not None, err.value.rule
    return set(m.group(1).split(", "))


@pytest.mark.parametrize("group", OPTION_GROUP_NAMES)
def test_the_validator_allows_exactly_the_tables_options(group: str) -> None:
    assert _allowed_by_refusal(group) == {f.name for f in option_fields(group)}


@pytest.mark.parametrize("field", [f for f in OPTION_FIELDS if f.max_text], ids=lambda f: f.pointer)
def test_the_text_length_limit_is_the_validators(field: OptionField) -> None:
    inside = "1." + "0" * (field.max_text - 2)  # max_text characters, the value 1
    assert len(inside) == field.max_text and field.admits(Fraction(inside))
    _validate(field.group, _options(field, inside), _bases(field)[0])
    with pytest.raises(InvalidInput) as err:  # one character more, the same value
        _validate(field.group, _options(field, inside + "0"), _bases(field)[0])
    assert err.value.field == field.pointer


def test_the_sweep_file_allows_exactly_the_tables_sweep_options() -> None:
    with pytest.raises(InvalidInput, match="sweep options are") as err:
        _validate("sweep", {"sweep": {"no_such_option": 1}})
    assert err.value.field == "/options/no_such_option"
    allowed = set(re.findall(r"'([a-z_]+)'", err.value.rule))
    assert allowed == {f.name for f in option_fields("sweep")}


def test_the_top_level_options_are_the_groups_and_the_tables_top_level_fields() -> None:
    assert _allowed_by_refusal("") == {*REQUEST_GROUPS, *(f.name for f in option_fields(""))}
    assert OPTION_KEYS == {g: frozenset(f.name for f in option_fields(g)) for g in REQUEST_GROUPS}


def test_the_outage_target_keys_are_the_tables() -> None:
    (target,) = [f for f in OPTION_FIELDS if f.kind == "object"]
    with pytest.raises(InvalidInput, match="allowed: threshold, epsilon, tolerance") as err:
        _validate("simulate", {"simulate": {"outage_target": {"threshold": 1, "epsilon": 0.5, "x": 1}}})
    assert err.value.field == f"{target.pointer}/x"
    for key in target.required:
        with pytest.raises(InvalidInput) as missing:
            _validate("simulate", {"simulate": {"outage_target": {k: 1 for k in target.required if k != key}}})
        assert missing.value.field == f"{target.pointer}/{key}"


def test_the_horizons_upper_end_is_the_largest_over_all_plants() -> None:
    horizon = next(f for f in OPTION_FIELDS if f.group == "bounds" and f.name == "horizon")
    assert max_horizon(1) == horizon.maximum and max_horizon(40) < horizon.maximum


# --- the published schemas say the same ------------------------------------------------------------------------


def _schema(name: str) -> dict[str, Any]:
    return json.loads((ROOT / "service" / "schemas" / f"{name}.json").read_text(encoding="utf-8"))


def _json_number(x: Any) -> Any:
    return int(x) if isinstance(x, int) or Fraction(x).denominator == 1 else float(x)


def _stated_bounds(schema: dict[str, Any]) -> dict[str, Any]:
    if schema.get("type") == "array":
        schema = schema["items"]
    branch = schema if schema.get("type") == "integer" else next(b for b in schema["anyOf"] if b["type"] == "number")
    return {k: v for k, v in branch.items() if k in ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum")}


def _published(field: OptionField) -> dict[str, Any]:
    top, _, sub = field.group.partition(".")
    if top == "loop":
        options = _schema("loop")["properties"]["options"]["properties"]
    elif top == "sweep":
        return dict(_schema("sweep")["properties"]["options"]["properties"][field.name])
    else:
        options = _schema("request")["$defs"]["Options"]["properties"]
    node = options if not top else options[top]["properties"]
    if sub:
        node = node[sub]["properties"]
    return dict(node[field.name])


@pytest.mark.parametrize("field", _all_fields(), ids=[f.pointer for f in _all_fields()])
def test_the_published_schema_states_the_tables_range_enum_and_default(field: OptionField) -> None:
    schema = _published(field)
    assert schema["description"] == field.description
    if field.kind in ("integer", "number", "number_list"):
        expected = {}
        for key, end, exclusive in (
            ("inimum", field.minimum, field.exclusive_minimum),
            ("aximum", field.maximum, field.exclusive_maximum),
        ):
            if end is not None:
                expected[("exclusiveM" if exclusive else "m") + key] = _json_number(end)
        assert _stated_bounds(schema) == expected
    if field.kind == "enum":
        assert schema["enum"] == list(field.enum)
    if field.kind == "number_list":
        assert schema["maxItems"] == field.max_items
    if field.max_text is not None:
        assert schema["anyOf"][1]["maxLength"] == field.max_text
    if field.default is not None and field.kind != "fixed":
        assert schema["default"] == _json_number(field.default) if field.kind != "enum" else field.default


def test_the_loops_time_budget_is_the_requests() -> None:
    loop = _schema("loop")["properties"]["options"]["properties"]["time_budget_s"]
    assert loop == _schema("request")["$defs"]["Options"]["properties"]["time_budget_s"]


def test_the_published_size_limits_are_the_validators() -> None:
    request = _schema("request")["$defs"]
    n = max(DEFAULT_LIMITS.max_analyze_states, DEFAULT_LIMITS.max_states)
    assert request["Matrix"]["maxItems"] == request["Matrix"]["items"]["maxItems"] == n
    assert request["System"]["properties"]["sensors"]["maxItems"] == DEFAULT_LIMITS.max_sensors
    assert request["MarkovChannel"]["properties"]["order"]["maximum"] == DEFAULT_LIMITS.max_markov_order
    table = request["MarkovChannel"]["properties"]["arrival_probability"]
    assert table["maxProperties"] == 2**DEFAULT_LIMITS.max_markov_order
    assert request["PerSensorChannel"]["properties"]["channels"]["maxProperties"] == DEFAULT_LIMITS.max_sensors
    assert request["ExactNumber"]["anyOf"][1]["maxLength"] == MAX_NUMBER_TEXT
    check = _schema("check")
    assert check["properties"]["checks"]["maxItems"] == MAX_CHECK_ENTRIES
    budget = check["properties"]["options"]["properties"]["time_budget_s"]["anyOf"][0]
    assert budget["maximum"] == MAX_RUN_BUDGET_S


def test_the_published_limits_are_the_validators_edges() -> None:
    """The size limits the schemas state are where the validator starts refusing."""
    n = DEFAULT_LIMITS.max_analyze_states
    eye = [[1 if i == j else 0 for j in range(n)] for i in range(n)]
    ok = {"system": {"A": eye, "C": [[1] * n]}, "channel": {"model": "bernoulli", "arrival_probability": 0.5}}
    load_request(json.dumps(ok), DEFAULT_LIMITS.for_command("analyze"))
    big = [[1 if i == j else 0 for j in range(n + 1)] for i in range(n + 1)]
    with pytest.raises(InvalidInput) as err:
        load_request(
            json.dumps({**ok, "system": {"A": big, "C": [[1] * (n + 1)]}}), DEFAULT_LIMITS.for_command("analyze")
        )
    assert err.value.field.startswith("/system/A")
    text = "1" * DEFAULT_LIMITS.max_digits
    load_request(json.dumps({**ok, "system": {"A": [[text]], "C": [[1]]}}))
    with pytest.raises(InvalidInput, match="characters"):
        load_request(json.dumps({**ok, "system": {"A": [["0" * (MAX_NUMBER_TEXT - 1) + "1" + "0"]], "C": [[1]]}}))
