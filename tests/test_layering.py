"""The layers of docs/contributing.md hold: every run-time import of kfio's code is one its table allows.

The table "What each package may import" is the single statement of the layers; this test reads it.
A row names a package (``kfio.loop``) and, outside parentheses, the packages, modules or names it may
import (``kfio.model``, ``kfio._json.view_of``); the header names the shared modules that every package
may import, and those import only each other. Imports inside functions count, imports under
``if TYPE_CHECKING:`` and in docstring examples do not (an example is the user's code, not the layer's).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from support.imports import PACKAGES, kfio_imports
from support.paths import ROOT

DOC = ROOT / "docs" / "contributing.md"
_NAME = re.compile(r"`(kfio(?:\.\w+)*)`")


@dataclass(frozen=True)
class Layers:
    """The table: the shared modules and names, and each row's allowed imports."""

    shared: tuple[str, ...]
    rows: dict[str, tuple[str, ...]]


def _outside_parentheses(text: str) -> str:
    out, depth = [], 0
    for ch in text:
        depth += ch == "("
        if not depth:
            out.append(ch)
        depth -= ch == ")" and depth > 0
    return "".join(out)


def read_layers(markdown: str) -> Layers:
    """The table that follows the words "What each package may import" in ``markdown``."""
    after = markdown[markdown.index("What each package may import") :].splitlines()
    table = []
    for line in after:
        if line.startswith("|"):
            table.append([c.strip() for c in line.strip().strip("|").split("|")])
        elif table:
            break
    header, _, *body = table
    rows: dict[str, tuple[str, ...]] = {}
    for package_cell, allowed_cell in body:
        (package,) = _NAME.findall(package_cell)
        assert package not in rows, f"two rows for {package}"
        rows[package] = tuple(_NAME.findall(_outside_parentheses(allowed_cell)))
    return Layers(tuple(_NAME.findall(header[1])), rows)


def _under(name: str, prefix: str) -> bool:
    return name == prefix or name.startswith(prefix + ".")


def layer_of(name: str, layers: Layers) -> str | None:
    """The row a module or imported name belongs to: ``"shared"``, a package of the table, or ``None``.

    The row ``kfio`` holds the top-level package itself and the names it exports; a top-level module
    (``kfio._api``) needs a row or a place among the shared modules of its own.
    """
    if any(_under(name, s) for s in layers.shared):
        return "shared"
    rows = [r for r in layers.rows if r != "kfio" and _under(name, r)]
    if rows:
        return max(rows, key=len)
    parts = name.split(".")
    if parts[0] == "kfio" and (len(parts) == 1 or (len(parts) == 2 and not parts[1].startswith("_"))):
        return "kfio" if "kfio" in layers.rows else None
    return None


def violations(layers: Layers, root: Path = ROOT, packages: tuple[tuple[str, str], ...] = PACKAGES) -> list[str]:
    """Every import of the code under ``root`` that ``layers`` does not allow, one line each."""
    out = set()
    for imp in kfio_imports(root, packages, examples=False):
        source = layer_of(imp.module, layers)
        if source is None:
            out.add(f"{imp.where(root)}: {imp.module} has no row in the table")
            continue
        target = layer_of(imp.target, layers)
        if target == source or target == "shared":
            continue
        if source == "shared":
            out.add(f"{imp.where(root)}: the shared {imp.module} imports {imp.target}, which is not shared")
            continue
        allowed = layers.rows[source]
        if any(_under(imp.target, a) or target == a for a in allowed):
            continue
        out.add(f"{imp.where(root)}: {source} imports {imp.target} ({target or 'no row'}); its row allows none")
    return sorted(out)


def test_every_import_is_one_the_table_allows() -> None:
    assert violations(read_layers(DOC.read_text())) == []


def test_the_table_is_read() -> None:
    """The parser sees the rows and ignores the explanations in parentheses."""
    layers = read_layers(DOC.read_text())
    assert {"kfio.errors", "kfio._budget", "kfio._json.encode"} <= set(layers.shared)
    assert layers.rows["kfio.model"] == ()
    assert layers.rows["kfio.search"] == ("kfio.structure",)
    assert "kfio.bounds" not in layers.rows["kfio.riccati_bounds"]
    assert "kfio.service" not in {a for allowed in layers.rows.values() for a in allowed}


def test_the_check_sees_a_layering_violation(tmp_path: Path) -> None:
    """Planted imports against a small table: a lower layer reaching up (in a function too), a module
    with no row, and a shared module importing a layer are reported; allowed and typing-only ones are not."""
    table = """What each package may import:

| package | may import (besides the shared `kfio.errors`) |
|---|---|
| `kfio.model` | nothing else (not even `kfio.structure`) |
| `kfio.structure` | `kfio.model` |
"""
    fake = tmp_path / "analyzer"
    for pkg in ("model", "structure", "extra"):
        (fake / pkg).mkdir(parents=True)
        (fake / pkg / "__init__.py").write_text("")
    (fake / "errors.py").write_text("from .model import X\n")
    (fake / "model" / "_a.py").write_text("from ..errors import E\ndef f():\n    from ..structure import Y\n")
    (fake / "model" / "_b.py").write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from ..structure import Y\n"
    )
    (fake / "structure" / "_c.py").write_text("from ..model import X\nfrom . import _d\n")
    (fake / "extra" / "_e.py").write_text("import kfio.model\n")
    assert violations(read_layers(table), tmp_path, (("analyzer", "kfio"),)) == [
        "analyzer/errors.py:1: the shared kfio.errors imports kfio.model.X, which is not shared",
        "analyzer/extra/_e.py:1: kfio.extra._e has no row in the table",
        "analyzer/model/_a.py:3: kfio.model imports kfio.structure.Y (kfio.structure); its row allows none",
    ]
