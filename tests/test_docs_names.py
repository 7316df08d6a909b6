"""Report attributes carry their JSON keys' names, with one documented exception.

``StabilityReport.gilbert_elliott`` is ``gilbert_elliott_region`` in the JSON;
``gilbert_elliott_region`` is also an attribute (the same object), and the docs say so.
"""

from __future__ import annotations

import re
from pathlib import Path

import kfio

ROOT = Path(__file__).resolve().parents[1]


def test_every_json_key_of_an_analysis_is_an_attribute_of_the_same_value() -> None:
    r = kfio.analyze(
        kfio.System(A=[[2, 0], [0, -2]], C=[[1, 1]]), kfio.gilbert_elliott(failure_rate=0.1, recovery_rate=0.3)
    )
    d = r.to_dict()
    assert d["gilbert_elliott_region"] is not None
    constants = {"kfio_version", "theorem"}  # written by the view, not report attributes
    missing = [key for key in d if key not in constants and not hasattr(r, key)]
    assert missing == []  # only because of the alias below
    assert r.gilbert_elliott_region.to_dict() == d["gilbert_elliott_region"]
    assert r.tail.to_dict() == d["tail"] and r.verdict == d["verdict"]
    assert r.gilbert_elliott_region is r.gilbert_elliott
    assert "gilbert_elliott_region" not in {f for f in r.__dataclass_fields__}  # an alias, not a second field


def test_the_mapping_is_documented() -> None:
    api = (ROOT / "docs" / "python_api.md").read_text(encoding="utf-8")
    assert "`r.gilbert_elliott`" in api and "`gilbert_elliott_region`" in api
    assert "gilbert_elliott_region" in kfio.StabilityReport.__doc__


def test_certified_is_defined_once_and_everything_else_links_there() -> None:
    theory = (ROOT / "docs" / "theory.md").read_text(encoding="utf-8")
    assert theory.count("### What `certified` means") == 1  # the anchor #what-certified-means
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    for page in pages:
        if page.name == "theory.md":
            continue
        for paragraph in page.read_text(encoding="utf-8").split("\n\n"):
            if re.search(r"`certified(: (true|false))?`[^.]*\b(means|says)\b", paragraph):
                assert "theory.md#what-certified-means" in paragraph, (page.name, paragraph[:120])
