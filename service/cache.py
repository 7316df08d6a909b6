"""In-memory LRU cache of answers, keyed by the canonical JSON of the request.

Two bodies that differ only in whitespace or key order are the same request.
Numbers keep their *text* (``1.10`` and ``1.1`` are different keys: a cache
miss, never a wrong hit), and a number is never confused with a string that
spells it, because the canonical form is built from the exact tree of
:func:`analyzer.load_json`, not from floats.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from decimal import Decimal
from typing import Any

from cachetools import LRUCache


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


class _Answers(LRUCache[str, tuple[CachedAnswer, int]]):
    """cachetools' LRU bounded in bytes (each value carries its size), and here in entries too."""

    def __init__(self, max_entries: int, max_bytes: int) -> None:
        super().__init__(max_bytes, getsizeof=_size_of)
        self.max_entries = max_entries

    def __setitem__(self, key: str, value: tuple[CachedAnswer, int]) -> None:
        super().__setitem__(key, value)  # evicts the least recently used until the bytes fit
        while len(self) > self.max_entries:
            self.popitem()


def _size_of(value: tuple[CachedAnswer, int]) -> int:
    return value[1]


class AnswerCache:
    """Least-recently-used cache bounded in entries and in bytes (body and key).

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
        self._items = _Answers(max_entries, max_bytes)
        self.hits = 0
        self.misses = 0

    def get(self, key: str) -> CachedAnswer | None:
        """The answer for ``key``, marked as recently used, or ``None``."""
        found = self._items.get(key)
        if found is None:
            self.misses += 1
            return None
        self.hits += 1
        return found[0]

    def put(self, key: str, answer: CachedAnswer) -> None:
        """Store ``answer``, evicting the least recently used ones to fit."""
        size = len(answer.content) + len(key)
        if self.max_entries == 0 or size > self.max_bytes:
            return
        # dropped first, so that only other answers are evicted to make room for its new size
        self._items.pop(key, None)
        self._items[key] = (answer, size)

    def __len__(self) -> int:
        return len(self._items)

    def stats(self) -> dict[str, int]:
        """Entries, bytes, hits and misses (for ``/readyz``)."""
        return {
            "entries": len(self._items),
            "bytes": int(self._items.currsize),
            "hits": self.hits,
            "misses": self.misses,
        }
