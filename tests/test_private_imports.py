"""Each subpackage has a public face: nothing outside a package imports its private modules or names.

A module ``kfio.X._y`` (and a name ``_z`` of any module) is private to the package that holds it: code
outside ``kfio.X`` imports what ``kfio.X``'s ``__init__`` names instead. The top-level private modules of
``kfio`` (``kfio._json``, ``kfio._budget``, ``kfio._reporting``, ...) are shared by the whole library and
its service. Imports inside functions count too; imports under ``if TYPE_CHECKING:`` do not (they
couple no code at run time, and naming the defining module there keeps the type aliases of
``kfio._typing`` out of an import cycle). Tests may reach in (they are the library's oracles).
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = (("analyzer", "kfio"), ("service", "kfio.service"))


def _module_name(folder: str, pkg: str, path: Path) -> str:
    parts = [p for p in path.relative_to(ROOT / folder).with_suffix("").parts if p != "__init__"]
    return ".".join([pkg, *parts])


def _target(name: str, is_package: bool, node: ast.ImportFrom) -> str:
    if not node.level:
        return node.module or ""
    base = name.split(".")[: None if is_package else -1]
    base = base[: len(base) - node.level + 1]
    return ".".join(base + ([node.module] if node.module else []))


def _runtime_imports(tree: ast.AST) -> list[ast.ImportFrom]:
    """Every ``from ... import`` of ``tree`` outside ``if TYPE_CHECKING:`` blocks."""
    out: list[ast.ImportFrom] = []

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
            for child in node.orelse:
                visit(child)
            return
        if isinstance(node, ast.ImportFrom):
            out.append(node)
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(tree)
    return out


def _violations() -> list[str]:
    out = []
    for folder, pkg in PACKAGES:
        for path in sorted((ROOT / folder).rglob("*.py")):
            name = _module_name(folder, pkg, path)
            for node in _runtime_imports(ast.parse(path.read_text())):
                target = _target(name, path.name == "__init__.py", node)
                if not target.startswith("kfio"):
                    continue
                for full in [target, *(f"{target}.{a.name}" for a in node.names)]:
                    parts = full.split(".")
                    private = [i for i, c in enumerate(parts) if c.startswith("_") and not c.startswith("__")]
                    if not private:
                        continue
                    owner = ".".join(parts[: private[0]])
                    if owner != "kfio" and name != owner and not name.startswith(owner + "."):
                        out.append(f"{path.relative_to(ROOT)}:{node.lineno} imports {full} from outside {owner}")
                    break
    return out


def test_no_package_reaches_into_another_packages_private_modules() -> None:
    assert _violations() == []


def test_the_check_sees_a_private_import(tmp_path: Path, monkeypatch) -> None:
    """The rule itself: a planted import of a private module from another package is reported."""
    fake = tmp_path / "analyzer"
    (fake / "model").mkdir(parents=True)
    (fake / "stability").mkdir()
    (fake / "model" / "__init__.py").write_text("")
    (fake / "model" / "_types.py").write_text("X = 1\n")
    (fake / "stability" / "__init__.py").write_text("from ..model import X\n")  # through the face: fine
    (fake / "stability" / "_v.py").write_text("def f():\n    from ..model._types import X\n")
    monkeypatch.setattr(__import__(__name__), "ROOT", tmp_path)
    monkeypatch.setattr(__import__(__name__), "PACKAGES", (("analyzer", "kfio"),))
    assert _violations() == ["analyzer/stability/_v.py:2 imports kfio.model._types from outside kfio.model"]
