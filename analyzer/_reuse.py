"""FMO blocks computed once per process for every request on the same ``(A, C, sensors)``.

The FMO blocks (Rohr, Marelli and Fu (2014), Section III) depend on ``A``,
``C`` and the split of ``C`` into packets only, never on the channel, ``Q`` or
``R``.  A design team that asks about one plant under many channels (a sweep,
or a series of requests to the service) needs them once.  The cache is keyed
by the exact values of ``A`` and ``C`` (rationals, never floats), bounded in
entries (least recently used), and stores only finished results: a
computation stopped by its budget leaves nothing behind.
"""

from __future__ import annotations

from collections import OrderedDict
from typing import TYPE_CHECKING, Any, Callable, Generic, Hashable, Sequence, TypeVar

from ._budget import Budget

if TYPE_CHECKING:
    from .structure import FmoBlock

#: What a plant's analysis derives from the plant alone, by key (see :func:`reused_plant` and :func:`kept`).
Memo = dict[Hashable, Any]

#: Plants whose blocks each process keeps.
STRUCTURE_ENTRIES = 256


V = TypeVar("V")


class LRU(Generic[V]):
    """A least-recently-used map with hit and miss counts.

    Examples
    --------
    >>> c = LRU(1)
    >>> c.get("a", lambda: 1), c.get("a", lambda: 2), c.get("b", lambda: 3), c.get("a", lambda: 4)
    (1, 1, 3, 4)
    >>> c.hits, c.misses
    (1, 3)
    """

    def __init__(self, size: int):
        self.size = size
        self.data: OrderedDict[Hashable, V] = OrderedDict()
        self.hits = 0
        self.misses = 0

    def get(self, key: Hashable, make: Callable[[], V]) -> V:
        """The value of ``key``, made by ``make()`` (and kept) when missing."""
        if key in self.data:
            self.data.move_to_end(key)
            self.hits += 1
            return self.data[key]
        self.misses += 1
        value = make()
        self.data[key] = value
        if len(self.data) > self.size:
            self.data.popitem(last=False)
        return value

    def clear(self) -> None:
        """Forget every entry and reset the counts."""
        self.data.clear()
        self.hits = self.misses = 0


_BLOCKS: LRU[tuple[Sequence[FmoBlock], Memo]] = LRU(STRUCTURE_ENTRIES)


def kept(memo: Memo | None, key: Hashable, compute: Callable[[], Any]) -> Any:
    """``compute()``, kept in ``memo`` under ``key`` when a memo is given (a plant's memo, see :func:`reused_plant`).

    Without a memo it is computed every time; with one, only the first time.
    """
    if memo is None:
        return compute()
    if key not in memo:
        memo[key] = compute()
    return memo[key]


def structure_key(system: Any) -> Hashable:
    """What the FMO blocks depend on: exact ``A``, exact ``C`` and the sensor rows."""
    sensors = None if system.sensors is None else tuple((s.name, s.rows) for s in system.sensors)
    return (system.A, system.C, sensors)


def reused_fmo_blocks(system: Any, budget: Budget | None = None) -> Sequence[FmoBlock]:
    """:func:`kfio.structure.fmo_blocks` of ``system``, computed once per process and plant.

    The blocks are frozen values, so every caller may share them
    (:func:`kfio.stability.analyze` takes them as ``fmo=``).  This module
    imports the exact structure code (SymPy, FLINT) only when first asked.
    """
    return reused_plant(system, budget)[0]


def reused_plant(system: Any, budget: Budget | None = None) -> tuple[Sequence[FmoBlock], Memo]:
    """The FMO blocks of ``system`` (as :func:`reused_fmo_blocks`) and the memo kept with them.

    The memo is a dict that belongs to these blocks alone (same key: exact
    ``A``, exact ``C``, the sensor rows), for :func:`kfio.stability.analyze`'s
    ``memo=``: what a point's analysis derives from the plant alone is kept
    there for the next point on the same plant.
    """
    from .structure import fmo_blocks

    global _LAST_PLANT
    last = _LAST_PLANT  # one read of an immutable pair: threads never see half of another call's
    if last is not None and last[0] is system:  # the very object of the last call (a sweep's plant): no hashing
        _BLOCKS.hits += 1
        return last[1]
    plant = _BLOCKS.get(structure_key(system), lambda: (fmo_blocks(system, budget), {}))
    _LAST_PLANT = (system, plant)  # holds the object, so its identity is never another's
    return plant


#: ``(system, (blocks, memo))`` of the last call to :func:`reused_plant`.
_LAST_PLANT: tuple[Any, tuple[Sequence[FmoBlock], Memo]] | None = None


def structure_cache() -> LRU[tuple[Sequence[FmoBlock], Memo]]:
    """This process's cache of FMO blocks (for statistics and tests)."""
    return _BLOCKS


def clear_plants() -> None:
    """Forget every kept plant (blocks and memos)."""
    global _LAST_PLANT
    _BLOCKS.clear()
    _LAST_PLANT = None
