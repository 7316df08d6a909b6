"""Which requests are cheap by size: the rule of the cheap lane.

With every regular worker busy on long requests (a loop at its 30 s budget,
say), a small ``analyze`` used to wait for one of them to finish.  The
dispatcher's pool therefore keeps ``KFIO_LANE_WORKERS`` reserved workers (one
by default) beside ``KFIO_WORKERS``; :class:`kfio.service.pool.WorkerPool`
gives a request that :func:`is_cheap` calls cheap a free regular worker when
there is one, else a reserved one, and moves it to a regular worker if it
runs past ``KFIO_LANE_BUDGET_S`` there (so a request misjudged as cheap holds
the lane for at most that long).  Every other request uses regular workers only.

The rule reads the request's JSON tree only (no validation, no arithmetic),
before any worker sees it.  A request is cheap when all of these hold:

* the command is ``analyze`` (Theorem 1's exact verdict; the other commands
  run Monte Carlo, SDP solvers or loop operators whose cost grows fast);
* the body is at most :data:`MAX_BODY_BYTES` bytes (this bounds the digits of
  every number, and the number of Markov histories and sensors);
* ``system.A`` has at most :data:`MAX_STATES` rows;
* a Markov channel, alone or per sensor, has order at most :data:`MAX_MARKOV_ORDER`;
* ``options.analyze`` asks for no design answer that grids the channel's
  parameters (``ge_grid``, ``critical_parameter``).

Examples
--------
>>> is_cheap("analyze", {"system": {"A": [[2]], "C": [[1]]}, "channel": {"model": "bernoulli"}}, 120)
True
>>> is_cheap("loop", {"system": {"A": [[2]]}}, 60)
False
"""

from __future__ import annotations

from typing import Any

#: Commands the lane takes.
COMMANDS = frozenset({"analyze"})

#: Largest body (bytes) the lane takes.
MAX_BODY_BYTES = 4096

#: Largest state dimension (rows of ``A``) the lane takes.
MAX_STATES = 4

#: Largest order of a Markov channel the lane takes.
MAX_MARKOV_ORDER = 3

#: ``options.analyze`` members that make an analysis a design study (grids and critical values).
COSTLY_OPTIONS = frozenset({"ge_grid", "critical_parameter"})


def is_cheap(command: str, tree: Any, body_bytes: int) -> bool:
    """True when ``tree``, the JSON of a ``command`` request of ``body_bytes`` bytes, is cheap by size.

    See the module docstring for the rule; anything unexpected (a malformed
    tree) is not cheap, and validation in a regular worker says why.
    """
    if command not in COMMANDS or body_bytes > MAX_BODY_BYTES or not isinstance(tree, dict):
        return False
    system = tree.get("system")
    matrix = system.get("A") if isinstance(system, dict) else None
    if not isinstance(matrix, list) or len(matrix) > MAX_STATES:
        return False
    if not _cheap_channel(tree.get("channel")):
        return False
    options = tree.get("options")
    analyze = options.get("analyze") if isinstance(options, dict) else None
    return not (isinstance(analyze, dict) and COSTLY_OPTIONS & analyze.keys())


def _cheap_channel(channel: Any) -> bool:
    if not isinstance(channel, dict):
        return False
    if channel.get("model") == "per_sensor":
        inner = channel.get("channels")
        return isinstance(inner, dict) and all(_cheap_channel(c) for c in inner.values())
    if channel.get("model") == "markov":
        order = channel.get("order")
        return isinstance(order, int) and not isinstance(order, bool) and order <= MAX_MARKOV_ORDER
    return True
