"""Comments, docstrings and docs say why, never when.

A reader of the code or the docs needs what a line does and why; the tracker's
numbers and "as it was earlier" age at once and mean nothing to them.  This
fails on a mention of a tracker issue by number or on the phrase "as" + "before"
in the library, the service, the tests, the benchmarks and the docs.  The
history pages are exempt: they record what was measured when, by design.
"""

from __future__ import annotations

import re
from pathlib import Path

from support.paths import ROOT

FOLDERS = ("analyzer", "service", "tests", "bench", "docs")
SUFFIXES = {".py", ".md", ".js", ".html", ".css", ".json", ".yaml", ".yml", ".toml", ".txt", ".sh"}
#: History pages: what was measured or changed when is their subject.
EXEMPT = {"docs/speed-history.md", "CHANGELOG.md"}
#: Written with ``\s`` so that this file does not match itself.
NARRATION = re.compile(r"\bas\s+before\b|\b[Ii]ssue\s+\d+")


def _texts() -> list[Path]:
    out = []
    for folder in FOLDERS:
        for path in sorted((ROOT / folder).rglob("*")):
            rel = path.relative_to(ROOT).as_posix()
            if path.is_file() and path.suffix in SUFFIXES and rel not in EXEMPT and "__pycache__" not in rel:
                out.append(path)
    return out


def test_the_scan_sees_the_code_and_the_docs() -> None:
    names = {p.relative_to(ROOT).as_posix() for p in _texts()}
    assert {"analyzer/__init__.py", "service/cli.py", "tests/test_comments.py", "docs/contributing.md"} <= names
    assert "docs/speed-history.md" not in names


def test_no_comment_narrates_history() -> None:
    found = []
    for path in _texts():
        for number, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
            if NARRATION.search(line):
                found.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()[:100]}")
    assert not found, "say what and why instead:\n" + "\n".join(found)


def test_the_pattern_catches_what_it_forbids() -> None:
    assert NARRATION.search("the same output as" + " before")
    assert NARRATION.search("(" + "issue" + " 21, item 5)")
    assert NARRATION.search("Issue" + " 6: regions")
    assert not NARRATION.search("it was before the lane; issues are tracked; test_issue12_reproducer")
