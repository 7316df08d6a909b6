"""Validate sweep points with each distinct plant parsed once.

A grid over the channel, or over one entry of ``A`` times the channel,
repeats the same ``system`` object in thousands of points.  Its validation
(:func:`kfio.model.parse_system`: exact numbers, ``Q`` PSD, ``R`` PD) is most
of the cost of checking a point, and its result depends on that subtree and
the limits alone.  So the first point with a given ``system`` runs the whole
single-request validator, and later points hand its :class:`kfio.model.System`
to :func:`kfio.model.parse_request`, which still validates the rest of the
request (top-level keys, channel, options) as for any request.
"""

from __future__ import annotations

import pickle
from typing import Any

from .._reuse import LRU
from ..model import DEFAULT_LIMITS, Limits, Request, SystemRecord, parse_request

#: Distinct plants each process keeps validated.
SYSTEM_ENTRIES = 256

_SYSTEMS: LRU[SystemRecord] = LRU(SYSTEM_ENTRIES)


def parse_point(tree: Any, limits: Limits = DEFAULT_LIMITS) -> Request:
    """:func:`kfio.model.parse_request` of ``tree``, the same request or the same error, faster on a shared plant.

    The cache key is the pickle of the ``system`` subtree (its exact JSON
    values with their types: the decimal text of a number, never a float)
    and ``limits``; equal keys are equal subtrees, so the cached
    :class:`kfio.model.System` is what :func:`kfio.model.parse_system` would
    return.  Only a plant that validated is kept: a bad one raises its error
    at every point that has it.
    """
    system_tree = tree.get("system") if isinstance(tree, dict) else None
    if system_tree is None:
        return parse_request(tree, limits)
    made: list[Request] = []

    def first() -> SystemRecord:
        made.append(parse_request(tree, limits))
        return made[0].system

    key = (pickle.dumps(system_tree, protocol=pickle.HIGHEST_PROTOCOL), limits)
    system = _SYSTEMS.get(key, first)
    return made[0] if made else parse_request(tree, limits, system=system)


def system_cache() -> LRU[SystemRecord]:
    """This process's cache of validated plants (for statistics and tests)."""
    return _SYSTEMS
