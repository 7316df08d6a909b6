"""The lazy packages name each public name three times, and the three must agree.

``kfio`` and its subpackages ``loop``, ``fit``, ``sweep`` and ``check`` load
their names on first use (``kfio._lazy.lazy_names``): a table of name ->
defining module serves the run time, an ``if TYPE_CHECKING:`` block of imports
serves type checkers and editors, and ``__all__`` is the public list.  A name
missing from one of them is a name that fails at run time, is ``Any`` for
mypy, or is undocumented; this test fails on each.
"""

from __future__ import annotations

import ast
import importlib

import pytest

from support.paths import ROOT

PACKAGES = {
    "kfio": "analyzer/__init__.py",
    **{f"kfio.{p}": f"analyzer/{p}/__init__.py" for p in ("loop", "fit", "sweep", "check")},
}


def _type_checking_names(tree: ast.Module) -> set[str]:
    names: set[str] = set()
    for node in tree.body:
        if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
            for stmt in ast.walk(node):
                if isinstance(stmt, ast.ImportFrom):
                    names |= {a.asname or a.name for a in stmt.names}
    return names


@pytest.mark.parametrize("package", sorted(PACKAGES))
def test_the_table_the_type_checking_imports_and_all_name_the_same(package: str) -> None:
    module = importlib.import_module(package)
    table = set(vars(module)["_LAZY"])
    public = set(module.__all__) - {"__version__"}
    assert table == public, (sorted(table - public), sorted(public - table))
    typed = _type_checking_names(ast.parse((ROOT / PACKAGES[package]).read_text()))
    assert typed == table, (sorted(typed - table), sorted(table - typed))


@pytest.mark.parametrize("package", sorted(PACKAGES))
def test_every_lazy_name_loads_from_the_module_its_table_names(package: str) -> None:
    module = importlib.import_module(package)
    for name, where in vars(module)["_LAZY"].items():
        defining = importlib.import_module(where, package)
        assert getattr(module, name) is getattr(defining, name), f"{package}.{name}"
