"""Every "Author (YEAR)" citation in shipped text is an entry of docs/references.md.

One citation per paper: the bold headings of docs/references.md are the cite keys
(``Rohr, Marelli and Fu (2014)``), and every author-year citation in the README,
the docs, the package's Python sources (docstrings, CLI and report text), the web
page's files, the OpenAPI document and the examples must name one of them, with
its year, in one of the forms ``Authors (YEAR)``, ``Authors YEAR`` or
``(Authors, YEAR)``.  "Rohr, Marelli, Fu 2014", "Rohr et al. 2010" or
"Sinopoli et al. (2003)" (the technical report of the 2004 paper) fail.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
REFERENCES = ROOT / "docs" / "references.md"

#: A citation: capitalized author names ("A, B and C", "A et al.") followed by a year.
CITE = re.compile(r"\b([A-Z][a-zA-Z-]+(?:(?:,| and) [A-Z][a-zA-Z-]+)*(?: et al\.?)?),? \(?((?:19|20)\d\d)\b")
#: Dates are not citations ("December 2004", "18 May 2003").
MONTHS = {
    "January",
    "February",
    "March",
    "April",
    "May",
    "June",
    "July",
    "August",
    "September",
    "October",
    "November",
    "December",
}
TEXT_SUFFIXES = {".md", ".py", ".js", ".html", ".css", ".json", ".txt"}

#: Citations in files other engineers own, fixed on their branches: each entry is
#: (file, citation as written).  The test fails on any other bad citation, and also when a
#: listed one is gone, so the list shrinks to nothing as the fixes land.
PENDING: set[tuple[str, str]] = set()


def cite_keys() -> set[tuple[str, str]]:
    """``(authors, year)`` of every bold ``**Authors (YEAR)**`` heading of docs/references.md."""
    keys = set(re.findall(r"^\*\*(.+?) \(((?:19|20)\d\d)\)\*\*$", REFERENCES.read_text(encoding="utf-8"), flags=re.M))
    assert len(keys) >= 10
    return keys


def shipped_files() -> list[Path]:
    files = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    for folder in ("analyzer", "service", "openapi", "examples"):
        files += sorted(p for p in (ROOT / folder).rglob("*") if p.is_file() and p.suffix in TEXT_SUFFIXES)
    return [p for p in files if p != REFERENCES]


def normalized(text: str) -> str:
    """Text with Python's split strings and comments rejoined and whitespace collapsed."""
    text = re.sub(r"(['\"])\s*\n\s*f?(['\"])", "", text)  # "... (Kar, "\n "Sinopoli and Moura 2012)"
    text = re.sub(r"\n\s*#\s*", " ", text)
    return re.sub(r"\s+", " ", text)


def citations(text: str) -> list[tuple[str, str, str]]:
    """``(written form, authors, year)`` of each author-year citation in ``text``."""
    out = []
    for m in CITE.finditer(normalized(text)):
        authors, year = m.group(1), m.group(2)
        if authors.split()[-1] in MONTHS:
            continue
        out.append((m.group(0).rstrip(), authors, year))
    return out


def _known(authors: str, year: str, keys: set[tuple[str, str]]) -> bool:
    # "Theorem 1 of Rohr, Marelli and Fu": the match may start with capitalized words before the authors
    return any(year == y and (authors == a or authors.endswith(" " + a)) for a, y in keys)


def test_the_scanner_finds_citations_and_refuses_variants() -> None:
    keys = cite_keys()
    found = citations(
        "as in Rohr, Marelli and Fu (2014), Theorem 1; see (Sinopoli et al., 2004) and\n    Liu and Goldsmith 2004"
    )
    assert [(a, y) for _, a, y in found] == [
        ("Rohr, Marelli and Fu", "2014"),
        ("Sinopoli et al.", "2004"),
        ("Liu and Goldsmith", "2004"),
    ]
    assert all(_known(a, y, keys) for _, a, y in found)
    for bad in ("Rohr, Marelli, Fu 2014", "Rohr et al. 2010", "Sinopoli et al. (2003)", "Rohr, Marelli and Fu 2011"):
        ((_, a, y),) = citations(bad)
        assert not _known(a, y, keys), bad
    assert citations("Berkeley, 18 May 2003, and December 2004") == []


def test_every_citation_in_shipped_text_is_a_reference() -> None:
    keys = cite_keys()
    bad: set[tuple[str, str]] = set()
    for path in shipped_files():
        rel = str(path.relative_to(ROOT))
        for written, authors, year in citations(path.read_text(encoding="utf-8", errors="replace")):
            if not _known(authors, year, keys):
                bad.add((rel, written.rstrip(",;.")))
    unexpected = {b for b in bad if not any(b[0] == f and b[1].endswith(c) for f, c in PENDING)}
    assert not unexpected, "citations not in docs/references.md (or not in its form):\n" + "\n".join(
        sorted(f"{f}: {c}" for f, c in unexpected)
    )
    stale = {(f, c) for f, c in PENDING if not any(b[0] == f and b[1].endswith(c) for b in bad)}
    assert not stale, f"fixed since: remove from PENDING {sorted(stale)}"
