"""The run-time imports of kfio's own modules, read from the source (for the privacy and layering tests).

An import counts when it runs: at module level, inside a function, or in a docstring example
(``>>> from kfio.model import ...``, which ``tests/test_doctests.py`` runs and a reader copies).
Imports under ``if TYPE_CHECKING:`` do not count: they couple no code at run time, and naming the
defining module there keeps the type aliases of ``kfio._typing`` out of an import cycle.
"""

from __future__ import annotations

import ast
import doctest
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from support.paths import ROOT

#: Source folder -> the package it installs as.
PACKAGES = (("analyzer", "kfio"), ("service", "kfio.service"))

_DOCTESTS = doctest.DocTestParser()


@dataclass(frozen=True)
class Import:
    """One imported module or name, resolved to its full dotted path (``kfio.model._types.Request``)."""

    module: str  #: the importing module
    path: Path  #: its file
    line: int  #: the line of the import statement (of the docstring, for an example)
    target: str  #: the module imported, or ``module.name`` for each name of a ``from`` import
    names: tuple[str, ...]  #: the names of a ``from`` import (empty for ``import x``)

    def where(self, root: Path) -> str:
        """``file:line`` relative to ``root``."""
        return f"{self.path.relative_to(root)}:{self.line}"


def module_name(folder: Path, pkg: str, path: Path) -> str:
    """The dotted name of the module in ``path`` (``folder`` installs as ``pkg``)."""
    parts = [p for p in path.relative_to(folder).with_suffix("").parts if p != "__init__"]
    return ".".join([pkg, *parts])


def _resolved(name: str, is_package: bool, node: ast.ImportFrom) -> str:
    if not node.level:
        return node.module or ""
    base = name.split(".")[: None if is_package else -1]
    base = base[: len(base) - node.level + 1]
    return ".".join(base + ([node.module] if node.module else []))


def runtime_import_nodes(tree: ast.AST) -> list[ast.Import | ast.ImportFrom]:
    """Every import statement of ``tree`` outside ``if TYPE_CHECKING:`` blocks."""
    out: list[ast.Import | ast.ImportFrom] = []

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
            for child in node.orelse:
                visit(child)
            return
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            out.append(node)
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(tree)
    return out


def _docstrings(tree: ast.AST) -> Iterator[tuple[int, str]]:
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                if isinstance(body[0].value.value, str):
                    yield body[0].lineno, body[0].value.value


def _example_nodes(tree: ast.AST) -> Iterator[tuple[int, ast.Import | ast.ImportFrom]]:
    """The import statements of the docstring examples of ``tree``, with the docstring's line."""
    for line, text in _docstrings(tree):
        for example in _DOCTESTS.get_examples(text):
            try:
                parsed = ast.parse(example.source)
            except SyntaxError:  # pragma: no cover - tests/test_doctests.py runs every example
                continue
            for node in runtime_import_nodes(parsed):
                yield line + example.lineno, node


def _imports_of(name: str, path: Path, node: ast.Import | ast.ImportFrom, line: int) -> Iterator[Import]:
    if isinstance(node, ast.Import):
        for alias in node.names:
            yield Import(name, path, line, alias.name, ())
        return
    base = _resolved(name, path.name == "__init__.py", node)
    names = tuple(a.name for a in node.names)
    for alias in node.names:
        yield Import(name, path, line, f"{base}.{alias.name}", names)


def kfio_imports(
    root: Path = ROOT, packages: tuple[tuple[str, str], ...] = PACKAGES, *, examples: bool = True
) -> Iterator[Import]:
    """Every run-time import of a ``kfio`` module or name by the modules of ``packages`` under ``root``
    (with ``examples``, those of the docstring examples too)."""
    for folder, pkg in packages:
        for path in sorted((root / folder).rglob("*.py")):
            name = module_name(root / folder, pkg, path)
            tree = ast.parse(path.read_text())
            found = [(n.lineno, n) for n in runtime_import_nodes(tree)]
            if examples:
                found += list(_example_nodes(tree))
            for line, node in found:
                for imp in _imports_of(name, path, node, line):
                    if imp.target == "kfio" or imp.target.startswith("kfio."):
                        yield imp
