"""Size limits applied to every request (configurable per deployment)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Limits:
    """Upper bounds on request sizes.

    The defaults are the ones promised in the README; a deployment may pass
    its own instance to :func:`kfio.parse_request`.
    """

    max_states: int = 40
    max_markov_order: int = 10
    max_digits: int = 200
    max_outputs: int = 40
    max_sensors: int = 8


DEFAULT_LIMITS = Limits()
