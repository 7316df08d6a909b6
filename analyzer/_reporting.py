"""What every report shares: the version stamp, the JSON text and a short repr.

The JSON of each report is built by its ``to_dict``, which starts with
``**stamp()``: ``kfio_version`` comes first in every one, and :func:`json_text` is the one way that
JSON becomes text (the CLI's ``--json``, the HTTP body and ``to_json()``).
"""

from __future__ import annotations

import json
from typing import Any, ClassVar

from ._version import __version__


def stamp() -> dict[str, Any]:
    """The fields every report's JSON starts with: ``{"kfio_version": ...}``."""
    return {"kfio_version": __version__}


def json_text(report: dict[str, Any]) -> str:
    """Stable JSON text: keys in the order built, two-space indent, no NaN."""
    return json.dumps(report, indent=2, allow_nan=False)


class ShortRepr:
    """A ``repr`` of a few telling attributes instead of every field."""

    _repr_fields: ClassVar[tuple[str, ...]] = ()

    def _repr_items(self) -> list[tuple[str, Any]]:
        return [(name, getattr(self, name)) for name in self._repr_fields]

    def __repr__(self) -> str:
        items = ", ".join(f"{k}={_short(v)}" for k, v in self._repr_items())
        return f"{type(self).__name__}({items})"


class Report(ShortRepr):
    """A top-level report: ``to_dict()`` (the ``--json`` object) and :meth:`to_json` (its text)."""

    def to_dict(self) -> dict[str, Any]:  # pragma: no cover - every report defines it
        raise NotImplementedError

    @property
    def kfio_version(self) -> str:
        """The version of kfio that made the report."""
        return __version__

    def to_json(self) -> str:
        """The JSON text that ``kfio <command> --json`` prints for the same request, byte for byte."""
        return json_text(self.to_dict())


def _short(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, tuple) and value and not isinstance(value[0], ShortRepr):
        return "(" + ", ".join(_short(v) for v in value) + ("," if len(value) == 1 else "") + ")"
    return repr(value)
