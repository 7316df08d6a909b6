"""Each subpackage has a public face: nothing outside a package imports its private modules or names.

A module ``kfio.X._y`` (and a name ``_z`` of any module) is private to the package that holds it: code
outside ``kfio.X`` imports what ``kfio.X``'s ``__init__`` names instead. The top-level private modules of
``kfio`` (``kfio._json``, ``kfio._budget``, ``kfio._reporting``, ...) are shared by the whole library and
its service, but not the modules inside them (``kfio._json._registry``). Imports inside functions and in
docstring examples count; imports under ``if TYPE_CHECKING:`` do not (see ``tests/support/imports.py``).
Tests may reach in (they are the library's oracles).
"""

from __future__ import annotations

from pathlib import Path

from support.imports import PACKAGES, kfio_imports
from support.paths import ROOT


def _private_part(target: str) -> tuple[str, str] | None:
    """``(owner package, the private module or name)`` of ``target``; ``None`` when nothing in it is private
    to a package (the top-level private modules of ``kfio`` are shared, but not the modules inside them)."""
    parts = target.split(".")
    private = [i for i, c in enumerate(parts) if c.startswith("_") and not c.startswith("__")]
    if private and private[0] == 1:
        private = private[1:]
        if not private:
            return None
        owner = ".".join(parts[:2])
    elif private:
        owner = ".".join(parts[: private[0]])
    else:
        return None
    return owner, ".".join(parts[: private[0] + 1])


def _violations(root: Path = ROOT, packages: tuple[tuple[str, str], ...] = PACKAGES) -> list[str]:
    out = set()
    for imp in kfio_imports(root, packages):
        found = _private_part(imp.target)
        if found is None:
            continue
        owner, private = found
        if imp.module != owner and not imp.module.startswith(owner + "."):
            out.add(f"{imp.where(root)} imports {private} from outside {owner}")
    return sorted(out)


def test_no_package_reaches_into_another_packages_private_modules() -> None:
    assert _violations() == []


def test_the_check_sees_a_private_import(tmp_path: Path) -> None:
    """The rule itself: planted imports of private modules from another package are reported,
    in a function, in a docstring example and inside a shared top-level package."""
    fake = tmp_path / "analyzer"
    (fake / "model").mkdir(parents=True)
    (fake / "stability").mkdir()
    (fake / "_json").mkdir()
    (fake / "model" / "__init__.py").write_text("")
    (fake / "model" / "_types.py").write_text("X = 1\n")
    (fake / "_json" / "__init__.py").write_text("from ._encode import encode\n")
    (fake / "_json" / "_encode.py").write_text("def encode(x):\n    return x\n")
    (fake / "stability" / "__init__.py").write_text("from ..model import X\nfrom .._json import encode\n")  # faces
    (fake / "stability" / "_v.py").write_text("def f():\n    from ..model._types import X\n")
    (fake / "stability" / "_w.py").write_text('"""Example.\n\n>>> from kfio.model._types import X\n"""\n')
    (fake / "stability" / "_x.py").write_text("from .._json._encode import encode\n")
    (fake / "stability" / "_y.py").write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from ..model._types import X\n"
    )
    assert _violations(tmp_path, (("analyzer", "kfio"),)) == [
        "analyzer/stability/_v.py:2 imports kfio.model._types from outside kfio.model",
        "analyzer/stability/_w.py:3 imports kfio.model._types from outside kfio.model",
        "analyzer/stability/_x.py:1 imports kfio._json._encode from outside kfio._json",
    ]
