"""Size limits applied to every request (configurable per deployment)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache


@dataclass(frozen=True)
class Limits:
    """Upper bounds on request sizes.

    The defaults are the ones promised in the README; a deployment may pass
    its own instance to :func:`kfio.parse_request`.

    ``max_states`` bounds the state dimension of every command's request but
    ``analyze``'s, which may have up to ``max_analyze_states`` states: the exact
    verdict (certified eigenstructure, FMO blocks, ``sigma_k``) of a dense
    ``n = 120`` plant takes under two seconds, while ``bounds`` solves Stein
    equations in ``n(n+1)/2`` unknowns and ``simulate`` keeps ``n x n``
    covariances per trajectory.  Each door validates with
    :meth:`for_command` of the command it runs.
    """

    max_states: int = 40
    max_analyze_states: int = 120
    max_markov_order: int = 10
    max_digits: int = 200
    max_outputs: int = 40
    max_sensors: int = 8

    @lru_cache(maxsize=64)  # noqa: B019 - frozen, hashable and few: a sweep asks once per point
    def for_command(self, command: str | None) -> Limits:
        """The limits a request for ``command`` is validated with.

        ``"analyze"`` gets ``max_states = max(max_states, max_analyze_states)``;
        every other command (and ``None``, a request not yet tied to one) keeps
        these limits.

        >>> Limits().for_command("analyze").max_states, Limits().for_command("bounds").max_states
        (120, 40)
        """
        if command == "analyze" and self.max_analyze_states > self.max_states:
            return replace(self, max_states=self.max_analyze_states)
        return self


DEFAULT_LIMITS = Limits()
