"""Look up a library function by name, or report it missing from this build.

Shared by the job table (:mod:`kfio.service.jobs`) and the figures
(:mod:`kfio.service.plots`), which therefore do not import each other.
"""

from __future__ import annotations

import importlib
from typing import Any, Callable

from .problems import Unavailable


def resolve(module: str, name: str) -> Callable[..., Any]:
    """``module.name``, or :class:`Unavailable` if this build does not have it."""
    try:
        mod = importlib.import_module(module)
    except ModuleNotFoundError as exc:
        if exc.name is not None and module.startswith(exc.name):
            raise Unavailable(f"{module} is not part of this build of kfio") from None
        raise
    fn = getattr(mod, name, None)
    if fn is None:
        raise Unavailable(f"{module}.{name} is not part of this build of kfio")
    return fn


__all__ = ["resolve"]
