"""Uvicorn stays inside the range the connection guard was proven on (it subclasses private classes)."""

from __future__ import annotations

import re
from importlib.metadata import version

from packaging.requirements import Requirement
from packaging.version import Version

from kfio.service.connection_guard import PROVEN_UVICORN

from support.paths import ROOT


def _pin_in(text: str) -> str:
    found = re.findall(r'^\s*"(uvicorn[^"]*)"', text, flags=re.MULTILINE)
    assert len(found) == 1, found
    return found[0]


def test_the_pyproject_pin_is_the_proven_range() -> None:
    low, high = PROVEN_UVICORN
    pin = Requirement(_pin_in((ROOT / "pyproject.toml").read_text()))
    assert pin.specifier == Requirement(f"uvicorn>={low},<{high}").specifier


def test_the_installed_uvicorn_is_one_the_guard_was_proven_on() -> None:
    low, high = (Version(v) for v in PROVEN_UVICORN)
    installed = Version(version("uvicorn"))
    assert low <= installed < high, (
        f"uvicorn {installed} is outside {PROVEN_UVICORN}: run the connection tests on it, then widen both"
    )
