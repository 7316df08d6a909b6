"""Run the ``python`` code blocks of docs/python_api.md, in order, in one namespace."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

DOC = Path(__file__).resolve().parents[2] / "docs" / "python_api.md"


def blocks() -> list[str]:
    return re.findall(r"^```python\n(.*?)^```$", DOC.read_text(encoding="utf-8"), flags=re.M | re.S)


def test_the_guide_has_examples_and_they_run():
    code = blocks()
    assert len(code) >= 6
    namespace: dict = {}
    with contextlib.redirect_stdout(io.StringIO()) as out:
        for i, block in enumerate(code):
            exec(compile(block, f"{DOC.name} block {i}", "exec"), namespace)  # noqa: S102 - our own docs
    assert "StabilityReport(verdict='stable'" in out.getvalue()
    assert "System(A=[['5/4', '0'], ['1', '11/10']], C=[['1', '1']])" in out.getvalue()
