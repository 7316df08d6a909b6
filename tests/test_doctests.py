"""Run the examples in every docstring of the installed ``kfio`` package.

The package is imported by its installed name (``kfio``), never from the
folders ``analyzer/`` and ``service/`` as top-level modules, so each module
exists once in ``sys.modules``.
"""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import kfio
import kfio.service


def _modules() -> list[str]:
    names = {"kfio", "kfio.service"}
    for package in (kfio, kfio.service):
        names.update(m.name for m in pkgutil.walk_packages(package.__path__, package.__name__ + "."))
    return sorted(names)


@pytest.mark.parametrize("name", _modules())
def test_docstring_examples(name: str) -> None:
    module = importlib.import_module(name)
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    for test in finder.find(module, name):
        runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{result.failed} of {result.attempted} docstring examples failed in {name}"
