"""The option tables of the docs are the validator's options.

The README's table lists every option as ``group.key``; docs/bounds.md and
docs/simulation.md list ``options.bounds`` and ``options.simulate``.  The names
are compared with what the validator itself allows: it names the allowed keys
when it refuses an unknown one.  A range written as ``A..B`` (integers) or as an
interval ``[a, b]`` / ``(a, b]`` is probed: both ends inside the range are
accepted, and a value just past each end is refused.
"""

from __future__ import annotations

import dataclasses
import json
import re
from decimal import Decimal
from pathlib import Path
from typing import Any

import pytest

from kfio import load_request
from kfio.errors import InvalidInput

from support.option_requests import BASES, NEEDS, VALIDATORS
from support.paths import ROOT


def validator_options(group: str) -> set[str]:
    """The keys the validator allows in ``options.<group>``, from its own refusal of an unknown key."""
    # the request parser refuses an unknown key of any group (whichever command runs), and so does the
    # group's own validator given a request built without the parser: both name the same allowed keys
    with pytest.raises(InvalidInput) as by_parser:
        load_request(json.dumps(dict(BASES["one"], options={group: {"no_such_option": 1}})))
    r = dataclasses.replace(load_request(json.dumps(BASES["one"])), options={group: {"no_such_option": 1}})
    with pytest.raises(InvalidInput) as err:
        VALIDATORS[group](r)
    assert err.value.field == by_parser.value.field == f"/options/{group}/no_such_option"
    m = re.search(r"allowed: (.*)$", err.value.rule)
    assert m is not None, err.value.rule
    assert by_parser.value.rule == err.value.rule
    return set(m.group(1).split(", "))


def all_validator_options() -> set[str]:
    names = {f"{g}.{k}" for g in VALIDATORS for k in validator_options(g)}
    # the top-level option, checked by the request parser itself
    with pytest.raises(InvalidInput, match="allowed|unknown|not allowed") as err:
        load_request(json.dumps(dict(BASES["one"], options={"no_such_group": {}})))
    assert err.value.field == "/options/no_such_group"
    return names | {"time_budget_s"}


def table(path: Path, first_header: str) -> list[list[str]]:
    """Rows (cells stripped) of the first table of ``path`` whose first header cell is ``first_header``."""
    lines = path.read_text(encoding="utf-8").splitlines()
    for i, line in enumerate(lines):
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.strip().startswith("|") and cells[0] == first_header:
            rows = []
            for row in lines[i + 2 :]:
                if not row.strip().startswith("|"):
                    break
                rows.append([c.strip() for c in re.split(r"(?<!\\)\|", row.strip().strip("|"))])
            return rows
    raise AssertionError(f"no table headed {first_header!r} in {path.name}")


def _name(cell: str) -> str:
    m = re.match(r"^`([a-zA-Z_.0-9]+)`", cell)
    assert m, f"option cell should start with `name`: {cell!r}"
    return m.group(1)


README_ROWS = table(ROOT / "README.md", "option")
GROUP_TABLES = {
    "bounds": table(ROOT / "docs" / "bounds.md", "`options.bounds` key"),
    "simulate": table(ROOT / "docs" / "simulation.md", "`options.simulate` key"),
}


def test_the_readme_table_lists_exactly_the_validators_options() -> None:
    assert {_name(r[0]) for r in README_ROWS} == all_validator_options()


@pytest.mark.parametrize("group", sorted(GROUP_TABLES))
def test_each_commands_table_lists_exactly_its_options(group: str) -> None:
    assert {_name(r[0]) for r in GROUP_TABLES[group]} == validator_options(group)


# --- ranges ---------------------------------------------------------------------------------------------------

_INT = r"(\d+)(?:\^(\d+))?(?:-(\d+))?"
INT_RANGE = re.compile(rf"`{_INT}\.\.{_INT}`")
INTERVAL = re.compile(r"`([\[(])([-0-9.e]+), ([-0-9.e]+)([\])])`")


def _int(base: str, power: str | None, minus: str | None) -> int:
    v = int(base) ** int(power) if power else int(base)
    return v - int(minus) if minus else v


def probes(cell: str) -> list[tuple[Any, bool]]:
    """``(value, accepted?)`` pairs for the first range written in ``cell``, or ``[]``."""
    m = INT_RANGE.search(cell)
    if m:
        lo, hi = _int(*m.groups()[:3]), _int(*m.groups()[3:])
        return [(lo, True), (hi, True), (lo - 1, False), (hi + 1, False)]
    m = INTERVAL.search(cell)
    if m:
        left, a, b, right = m.group(1), Decimal(m.group(2)), Decimal(m.group(3)), m.group(4)
        step = Decimal("1e-6")
        below = a * (1 - step) if a > 0 else a - step
        above = b * (1 + step) if b > 0 else b + step
        inside_a = a if left == "[" else (a * (1 + step) if a > 0 else a + step)
        inside_b = b if right == "]" else (b * (1 - step) if b > 0 else b - step)
        return [
            (inside_a, True),
            (inside_b, True),
            (below if left == "[" else a, False),
            (above if right == "]" else b, False),
        ]
    return []


def _check(option: str, value: Any, accepted: bool) -> None:
    group, _, key = option.rpartition(".")
    base = BASES[NEEDS.get(option, "one")]
    text = json.dumps(dict(base, options={key: "@"} if not group else {group: {key: "@"}}))
    text = text.replace('"@"', str(value))  # the number as JSON text, read exactly like a user's
    try:
        r = load_request(text)
        if group:
            VALIDATORS[group](r)
    except InvalidInput as exc:
        assert not accepted, f"{option} = {value} refused: {exc}"
        assert exc.field.endswith(f"/{key}"), exc.field
    else:
        assert accepted, f"{option} = {value} accepted, outside the documented range"


RANGED = [(_name(r[0]), r[1]) for r in README_ROWS if probes(r[1])] + [
    (f"{g}.{_name(r[0])}", r[2 if g == "simulate" else 1]) for g, rows in GROUP_TABLES.items() for r in rows
]
RANGED = [(name, cell) for name, cell in RANGED if probes(cell)]


def test_ranges_are_stated_for_the_numeric_options() -> None:
    stated = {name for name, _ in RANGED}
    assert {"analyze.ge_grid", "bounds.tolerance", "bounds.grid", "simulate.steps", "time_budget_s"} <= stated


@pytest.mark.parametrize(("option", "cell"), RANGED, ids=[f"{n}-{i}" for i, (n, _) in enumerate(RANGED)])
def test_a_stated_range_is_the_validators(option: str, cell: str) -> None:
    for value, accepted in probes(cell):
        _check(option, value, accepted)


@pytest.mark.parametrize("group", sorted(VALIDATORS))
def test_the_python_docstrings_name_every_option(group: str) -> None:
    import kfio

    doc = getattr(kfio, group).__doc__
    assert "none today" not in doc and "none yet" not in doc
    for key in validator_options(group):
        assert f"``{key}``" in doc or f"{key}," in doc or f"{key}:" in doc, (group, key)
