"""In-memory LRU cache of answers, keyed by the canonical JSON of the request.

Two bodies that differ only in whitespace or key order are the same request.
Numbers keep their *text* (``1.10`` and ``1.1`` are different keys: a cache
miss, never a wrong hit), and a number is never confused with a string that
spells it, because the canonical form is built from the exact tree of
:func:`analyzer.load_json`, not from floats.
"""

from __future__ import annotations

import json
from collections import OrderedDict
from dataclasses import dataclass
from decimal import Decimal
from typing import Any


def canonical_json(tree: Any) -> str:
    """Canonical text of a JSON tree from :func:`analyzer.load_json`.

    Objects have sorted keys, there is no whitespace, strings use
    :func:`json.dumps` escaping and numbers keep their text.

    Examples
    --------
    >>> from kfio import load_json
    >>> canonical_json(load_json('{"b": [1.10, "x"], "a": null}'))
    '{"a":null,"b":[1.10,"x"]}'
    """
    parts: list[str] = []
    _emit(tree, parts)
    return "".join(parts)


def _emit(node: Any, out: list[str]) -> None:
    # Iterative descent is not needed: load_json already bounds the depth.
    if isinstance(node, dict):
        out.append("{")
        for i, key in enumerate(sorted(node)):
            if i:
                out.append(",")
            out.append(json.dumps(key))
            out.append(":")
            _emit(node[key], out)
        out.append("}")
    elif isinstance(node, list):
        out.append("[")
        for i, item in enumerate(node):
            if i:
                out.append(",")
            _emit(item, out)
        out.append("]")
    elif isinstance(node, Decimal):
        out.append(str(node))
    else:  # str, int, bool, None
        out.append(json.dumps(node))


@dataclass(frozen=True)
class CachedAnswer:
    """A finished answer: the response body and its media type."""

    content: bytes
    media_type: str


class AnswerCache:
    """Least-recently-used cache bounded in entries and in bytes.

    Parameters
    ----------
    max_entries:
        Most answers kept; ``0`` disables the cache.
    max_bytes:
        Most bytes of answer bodies kept.

    Examples
    --------
    >>> c = AnswerCache(max_entries=1, max_bytes=100)
    >>> c.put("a", CachedAnswer(b"1", "application/json")); c.put("b", CachedAnswer(b"2", "application/json"))
    >>> c.get("a") is None, c.get("b").content
    (True, b'2')
    """

    def __init__(self, max_entries: int, max_bytes: int) -> None:
        self.max_entries = max_entries
        self.max_bytes = max_bytes
        self._items: OrderedDict[str, CachedAnswer] = OrderedDict()
        self._bytes = 0
        self.hits = 0
        self.misses = 0

    def get(self, key: str) -> CachedAnswer | None:
        """The answer for ``key``, marked as recently used, or ``None``."""
        answer = self._items.get(key)
        if answer is None:
            self.misses += 1
            return None
        self._items.move_to_end(key)
        self.hits += 1
        return answer

    def put(self, key: str, answer: CachedAnswer) -> None:
        """Store ``answer``, evicting the least recently used ones to fit."""
        size = len(answer.content) + len(key)
        if self.max_entries == 0 or size > self.max_bytes:
            return
        old = self._items.pop(key, None)
        if old is not None:
            self._bytes -= len(old.content) + len(key)
        self._items[key] = answer
        self._bytes += size
        while len(self._items) > self.max_entries or self._bytes > self.max_bytes:
            k, v = self._items.popitem(last=False)
            self._bytes -= len(v.content) + len(k)

    def __len__(self) -> int:
        return len(self._items)

    def stats(self) -> dict[str, int]:
        """Entries, bytes, hits and misses (for ``/readyz``)."""
        return {"entries": len(self._items), "bytes": self._bytes, "hits": self.hits, "misses": self.misses}
