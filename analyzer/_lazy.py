"""Names of a package that load on first use (PEP 562): ``kfio``, ``kfio.loop``, ``.fit``, ``.sweep``, ``.check``."""

from __future__ import annotations

import importlib
from typing import Any, Callable


def lazy_names(
    package: str, table: dict[str, str], namespace: dict[str, Any]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The module ``__getattr__`` and ``__dir__`` of ``package`` for the names in ``table``.

    ``table`` maps a public name to the module (relative to ``package``) that defines it; the
    first access imports that module and keeps the value in ``namespace`` (the package's
    ``globals()``), so later accesses cost nothing.
    """

    def __getattr__(name: str) -> Any:
        module = table.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module, package), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(table))

    return __getattr__, __dir__
