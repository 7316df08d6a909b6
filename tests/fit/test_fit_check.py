"""``kfio check`` entries that name a measured trace instead of a channel."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from kfio.check import load_check
from kfio.errors import InvalidInput
from kfio.service.cli import main as cli_main

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def layout(tmp_path: Path) -> Path:
    shutil.copy(ROOT / "examples/seed004_scalar.json", tmp_path / "plant.json")  # lambda_c = 9/25
    (tmp_path / "traces").mkdir()
    for name in ("iid_060.txt", "near_037.txt", "bursty.txt"):
        shutil.copy(ROOT / "examples/traces" / name, tmp_path / "traces" / name)
    (tmp_path / "traces/bad.txt").write_text("1\n0\n7\n")
    return tmp_path


def _write(layout: Path, entries: list) -> Path:
    path = layout / "check.json"
    path.write_text(json.dumps({"checks": entries}))
    return path


def test_verdict_is_judged_on_the_confidence_region(layout: Path, capsys) -> None:
    path = _write(
        layout,
        [
            {
                "name": "iid",
                "plant": "plant.json",
                "trace": "traces/iid_060.txt",
                "requirements": {"verdict": "stable"},
            },
            {
                "name": "short",
                "plant": "plant.json",
                "trace": "traces/near_037.txt",
                "requirements": {"verdict": "stable"},
            },
            {
                "name": "bursty",
                "plant": "plant.json",
                "trace": "traces/bursty.txt",
                "level": "0.99",
                "requirements": {"verdict": "unstable"},
            },
        ],
    )
    assert cli_main(["check", str(path), "--json"]) == 1
    outcomes = {o["entry"]: o for o in json.loads(capsys.readouterr().out)["outcomes"]}
    assert outcomes["iid"]["status"] == "pass" and outcomes["iid"]["measured"].startswith("stable at 95%")
    # the estimate 189/500 is stable, the region is not decided: the requirement fails, and says why
    assert outcomes["short"]["status"] == "fail"
    assert outcomes["short"]["measured"] == "undecided at 95% (estimate: stable)"
    assert "2807 packets" in outcomes["short"]["detail"]
    assert outcomes["bursty"]["status"] == "pass" and outcomes["bursty"]["measured"].startswith("unstable at 99%")


@pytest.mark.parametrize(
    ("entry", "field"),
    [
        ({"trace": "traces/bad.txt"}, "/checks/0/trace"),
        ({"trace": "traces/missing.txt"}, "/checks/0/trace"),
        ({"trace": "traces/iid_060.txt", "level": 2}, "/checks/0/level"),
        ({"level": "0.9"}, "/checks/0/level"),
        ({"trace": "traces/iid_060.txt", "channel": "plant.json"}, "/checks/0/trace"),
    ],
)
def test_bad_trace_entries_name_the_field(layout: Path, entry: dict, field: str) -> None:
    path = _write(layout, [{"plant": "plant.json", "requirements": {"verdict": "stable"}, **entry}])
    with pytest.raises(InvalidInput) as exc:
        load_check(path)
    assert exc.value.field == field
