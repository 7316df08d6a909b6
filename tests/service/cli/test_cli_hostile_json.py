"""Hostile JSON at the CLI, in process: every outcome is a documented exit code.

A seeded, bounded hypothesis campaign feeds ``kfio analyze``, ``bounds`` and
``simulate`` (through :func:`kfio.service.cli.main`, not subprocesses) with
mutated valid requests and random JSON: huge exponents (``1e999999999``),
integers of hundreds of digits, lone surrogates in keys and values, non-ASCII
digits and whitespace, wrong types, deep nesting within the parser's limits,
unknown and escaped keys.  Every run must end with an exit code in
``{0, 1, 2, 3, 4, 5}`` (no 70, the internal-error code) and print no traceback.
Figures (cases, time) are in docs/input-limits.md.
"""

from __future__ import annotations

import copy
import json
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from kfio.service.cli import main

ALLOWED_EXITS = {0, 1, 2, 3, 4, 5}


class Raw:
    """A JSON number written verbatim (``1e999999999`` has no Python float)."""

    def __init__(self, text: str) -> None:
        self.text = text


def dumps(node: Any) -> str:
    """JSON text; strings with ``ensure_ascii`` so lone surrogates become ``\\udXXX`` escapes."""
    if isinstance(node, Raw):
        return node.text
    if isinstance(node, dict):
        return "{" + ", ".join(f"{json.dumps(k)}: {dumps(v)}" for k, v in node.items()) + "}"
    if isinstance(node, list):
        return "[" + ", ".join(dumps(v) for v in node) + "]"
    return json.dumps(node)


HOSTILE_TEXT = [
    "1e999999999",
    "-1e999999999",
    "1e-999999999",
    "1e99999999999999999999",
    "0e999999999",
    "1" + "0" * 250,
    "9" * 199,
    "1/0",
    "0/0",
    "\u0661.\u0662\u0665",
    "\uff11\uff12",
    "1\x0b",
    "\x0c1",
    "NaN",
    "Infinity",
    "1e160",
    "-1e160",
    "1/3",
    "7/9e-100",
    "0.5",
    "",
    "\ud800",
    "a\udc00b",
    "$\\nosuchcmd$",
    "~1/~0",
]
RAW_NUMBERS = [
    "1e999999999",
    "-1e999999999",
    "1e-999999999",
    "1e99999999999999999999",
    "1.5e999999999",
    "1" + "0" * 300,
    "-0.0",
    "1e160",
    "1E+400",
    "123456789012345678901234567890",
    "0.5",
    "2",
    "-3",
    "1e3",
]

numbers = st.one_of(
    st.sampled_from(RAW_NUMBERS).map(Raw),
    st.sampled_from(HOSTILE_TEXT),
    st.integers(min_value=-(10**40), max_value=10**40),
    st.fractions(max_denominator=10**6).map(lambda f: f"{f.numerator}/{f.denominator}"),
    st.floats(allow_nan=False, allow_infinity=False, width=32),
    st.booleans(),
    st.none(),
)
keys = st.one_of(
    st.sampled_from(["A", "C", "Q", "R", "sensors", "model", "order", "steps", "grid", "horizon", "x"]),
    st.sampled_from(["\ud800", "s\udfff", "~0", "a/b", "", "0", "01", "1" * 12]),
    st.text(max_size=8),
)
json_trees = st.recursive(
    numbers | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(keys, inner, max_size=4),
    max_leaves=20,
)


def _base(kind: int) -> dict:
    bern = {"model": "bernoulli", "arrival_probability": "0.9"}
    options = {"simulate": {"steps": 10, "trajectories": 20}, "bounds": {"horizon": 1, "tolerance": 0.01}}
    if kind == 0:
        return {
            "system": {"A": [[1.2, 0], [1, 0.5]], "C": [[1, 1]], "Q": [[1, 0], [0, 1]], "R": [[1]]},
            "channel": bern,
            "options": options,
        }
    if kind == 1:
        return {
            "system": {"A": [[2]], "C": [[1]], "Q": [[1]], "R": [[1]]},
            "channel": {
                "model": "markov",
                "order": 2,
                "arrival_probability": {"00": 0.5, "01": 0.6, "10": 0.7, "11": 0.8},
            },
            "options": options,
        }
    return {
        "system": {
            "A": [[1.5, 0], [0, 1.2]],
            "C": [[1, 0], [0, 1]],
            "Q": [[1, 0], [0, 1]],
            "R": [[1, 0], [0, 1]],
            "sensors": [{"name": "s1", "rows": [0]}, {"name": "s2", "rows": [1]}],
        },
        "channel": {
            "model": "per_sensor",
            "channels": {"s1": bern, "s2": {"model": "gilbert_elliott", "failure_rate": 0.1, "recovery_rate": 0.8}},
        },
        "options": {"simulate": {"steps": 10, "trajectories": 20}},
    }


def _paths(node: Any, prefix: tuple = ()) -> list[tuple]:
    out = [prefix]
    if isinstance(node, dict):
        for k, v in node.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += _paths(v, (*prefix, i))
    return out


@st.composite
def requests(draw: st.DrawFn) -> Any:
    """A valid request with one to three mutations, or random JSON (sometimes deeply nested)."""
    choice = draw(st.integers(0, 9))
    if choice == 0:
        return draw(json_trees)
    if choice == 1:
        depth = draw(st.integers(1, 400))
        return {"system": Raw("[" * depth + "1" + "]" * depth), "channel": {}}
    body = copy.deepcopy(_base(draw(st.integers(0, 2))))
    for _ in range(draw(st.integers(1, 3))):
        paths = _paths(body)
        path = draw(st.sampled_from(paths))
        parent: Any = body
        for step in path[:-1]:
            parent = parent[step]
        action = draw(st.integers(0, 3))
        if not path:
            continue
        if action == 0:
            parent[path[-1]] = draw(numbers)
        elif action == 1:
            parent[path[-1]] = draw(json_trees)
        elif action == 2 and isinstance(parent, dict):
            parent[draw(keys)] = draw(numbers | json_trees)
        elif isinstance(parent, dict):
            del parent[path[-1]]
        elif isinstance(parent, list) and len(parent) > 1:
            parent.pop(path[-1])
    return body


def _run(command: str, body: Any, tmp_path, capsys, as_json: bool) -> None:
    path = tmp_path / "request.json"
    path.write_text(dumps(body), encoding="ascii")
    code = main([command, *(["--json"] if as_json else []), str(path)])
    out, err = capsys.readouterr()
    assert code in ALLOWED_EXITS, f"exit {code} for {dumps(body)[:300]}\n{err[-2000:]}"
    assert "Traceback" not in err, err[-2000:]
    if as_json and code in (0, 1, 3):
        json.loads(out)  # valid JSON: no NaN, no Infinity
    out.encode("utf-8")


CAMPAIGN = settings(
    max_examples=120,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow, HealthCheck.data_too_large],
)


@pytest.mark.slow
@pytest.mark.parametrize("command", ["analyze", "bounds", "simulate"])
@CAMPAIGN
@given(body=requests(), as_json=st.booleans())
def test_hostile_json_never_crashes_the_cli(command: str, body: Any, as_json: bool, tmp_path, capsys) -> None:
    _run(command, body, tmp_path, capsys, as_json)
