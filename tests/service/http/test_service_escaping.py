"""User text is escaped where it leaves kfio: JSON pointers per RFC 6901, terminal text without controls."""

from __future__ import annotations

import json
import random
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient

from kfio import InvalidInput, load_request
from kfio._reporting import terminal_text
from kfio.model import json_pointer, pointer_tokens
from kfio.service import exitcodes
from kfio.service.app import create_app
from kfio.service.cli import main
from kfio.service.settings import Settings

SLASH, TILDE = "a/", "b~c"
ESC_NAME = "s\x1b]0;pwned\x07\x1b[31m"  # sets the window title, then turns the text red
C1_NAME = "t\x9b2J"  # U+009B: a one-character CSI (erase the screen)


def two_sensor_request(names: tuple[str, str], probabilities: tuple[Any, Any] = ("9/10", "19/20")) -> dict:
    eye = [[1, 0], [0, 1]]
    return {
        "system": {
            "A": [[2, 0], [0, 3]],
            "C": eye,
            "Q": eye,
            "R": eye,
            "sensors": [{"name": names[0], "rows": [0]}, {"name": names[1], "rows": [1]}],
        },
        "channel": {
            "model": "per_sensor",
            "channels": {n: {"model": "bernoulli", "arrival_probability": p} for n, p in zip(names, probabilities)},
        },
    }


def resolve(tree: Any, pointer: str) -> Any:
    """The value ``pointer`` names in ``tree``, walked token by token (KeyError if it names none)."""
    for token in pointer_tokens(pointer):
        tree = tree[int(token)] if isinstance(tree, list) else tree[token]
    return tree


def test_json_pointer_round_trips_any_keys() -> None:
    rng = random.Random(22)
    alphabet = "~/01a"  # the two escaped characters, and the digits of the escapes themselves
    for _ in range(2000):
        keys = ["".join(rng.choice(alphabet) for _ in range(rng.randint(0, 5))) for _ in range(rng.randint(1, 4))]
        if keys == [""]:
            continue  # "/" is the whole request in kfio (kfio.model._pointer says why that is safe)
        pointer = json_pointer(keys)
        assert pointer_tokens(pointer) == keys
        # RFC 6901 section 3: a token never holds a raw "/" nor a "~" other than "~0", "~1"
        for token in pointer[1:].split("/"):
            assert token.replace("~0", "").replace("~1", "").count("~") == 0


@pytest.mark.parametrize(
    ("probabilities", "bad"),
    [(("2", "19/20"), 0), (("9/10", "-1"), 1), (("1", "19/20"), 0), (("9/10", "0"), 1)],
)
def test_errors_name_sensor_fields_by_escaped_pointers(probabilities: tuple[str, str], bad: int) -> None:
    body = two_sensor_request((SLASH, TILDE), probabilities)
    from kfio import analyze

    with pytest.raises(InvalidInput) as info:
        analyze(load_request(json.dumps(body)))
    field = info.value.field
    expected = ["/channel/channels/a~1/arrival_probability", "/channel/channels/b~0c/arrival_probability"][bad]
    assert field == expected
    assert resolve(body, field) == probabilities[bad]  # the page finds the value the error is about


def test_unknown_sensor_key_is_an_escaped_pointer() -> None:
    body = two_sensor_request((SLASH, TILDE))
    body["channel"]["channels"]["x/~y"] = {"model": "bernoulli", "arrival_probability": "1/2"}
    with pytest.raises(InvalidInput) as info:
        load_request(json.dumps(body))
    assert info.value.field == "/channel/channels/x~1~0y"
    assert resolve(body, info.value.field) == body["channel"]["channels"]["x/~y"]


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with TestClient(create_app(Settings(workers=1, job_workers=1))) as c:
        yield c


def test_http_422_field_is_an_escaped_pointer(client: TestClient) -> None:
    body = two_sensor_request((SLASH, TILDE), ("9/10", "3/2"))
    r = client.post("/v1/analyze", json=body)
    assert r.status_code == 422, r.text
    problem = r.json()
    assert problem["field"] == "/channel/channels/b~0c/arrival_probability"
    assert resolve(body, problem["field"]) == "3/2"


def test_terminal_text_shows_every_control_character() -> None:
    for code in [*range(0x20), 0x7F, *range(0x80, 0xA0), 0x202E, 0x2066]:
        shown = terminal_text(f"a{chr(code)}b")
        if chr(code) in "\n\t":
            assert shown == f"a{chr(code)}b"
        else:
            assert chr(code) not in shown and shown.startswith("a\\") and shown.endswith("b"), (code, shown)
    assert terminal_text("λ = 0.9 ≥ ½") == "λ = 0.9 ≥ ½"  # printable text is left alone


def controls(text: str) -> set[str]:
    return {c for c in text if (ord(c) < 0x20 and c not in "\n\t") or 0x7F <= ord(c) <= 0x9F}


def test_cli_summary_shows_sensor_names_without_their_controls(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "r.json"
    path.write_text(json.dumps(two_sensor_request((ESC_NAME, C1_NAME))))
    assert main(["analyze", str(path)]) == exitcodes.STABLE
    out = capsys.readouterr().out
    assert "sensor s\\x1b]0;pwned\\x07" in out and "t\\x9b2J" in out
    assert not controls(out)


def test_cli_error_line_shows_the_pointer_without_controls(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "r.json"
    path.write_text(json.dumps(two_sensor_request((ESC_NAME, "b/~"), ("9/10", "7"))))
    assert main(["analyze", str(path)]) == exitcodes.INVALID_INPUT
    err = capsys.readouterr().err
    assert "/channel/channels/b~1~0/arrival_probability" in err
    assert not controls(err)
    path.write_text(json.dumps(two_sensor_request((ESC_NAME, C1_NAME), ("9/10", "7"))))
    assert main(["analyze", str(path)]) == exitcodes.INVALID_INPUT
    err = capsys.readouterr().err
    assert "t\\x9b2J" in err and not controls(err)


@pytest.mark.parametrize(
    ("tree", "field"),
    [
        ({"options": {"a/b~c": 1}, "checks": []}, "/options/a~1b~0c"),
        ({"checks": [{"plant": "p.json", "requirements": {}, "x/~": 1}]}, "/checks/0/x~1~0"),
        ({"checks": [{"plant": "p.json", "requirements": {"m/e~an": 1}}]}, "/checks/0/requirements/m~1e~0an"),
    ],
)
def test_check_files_name_unknown_keys_by_escaped_pointers(tree: dict, field: str, tmp_path: Path) -> None:
    from kfio.check import parse_check

    plant = {"system": {"A": [[2]], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": "1/2"}}
    (tmp_path / "p.json").write_text(json.dumps(plant))
    with pytest.raises(InvalidInput) as info:
        parse_check(tree, base=tmp_path)
    assert info.value.field == field
