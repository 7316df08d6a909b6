"""Typed, frozen objects for a validated request (STYLE.md, habit 3).

Matrices are tuples of tuples of :class:`fractions.Fraction`: exact, hashable,
and convertible once at the edge (:func:`to_float`, :func:`to_domain`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from typing import TYPE_CHECKING, Any, Mapping, Union

import numpy as np

from ._pointer import json_pointer

if TYPE_CHECKING:
    from sympy.polys.matrices import DomainMatrix

Matrix = tuple[tuple[Fraction, ...], ...]


def to_float(m: Matrix) -> np.ndarray:
    """The matrix as a float64 array (the only float conversion point)."""
    return np.array([[float(x) for x in row] for row in m], dtype=float).reshape(len(m), -1 if m else 0)


def to_domain(m: Matrix) -> DomainMatrix:
    """The matrix as a SymPy :class:`DomainMatrix` over ``QQ``, exactly."""
    from sympy import QQ
    from sympy.polys.matrices import DomainMatrix

    rows = [[QQ(x.numerator, x.denominator) for x in row] for row in m]
    ncols = len(m[0]) if m else 0
    return DomainMatrix(rows, (len(m), ncols), QQ)


@dataclass(frozen=True)
class Sensor:
    """A packet: the rows of ``C`` (and the block of ``R``) it carries."""

    name: str
    rows: tuple[int, ...]


@dataclass(frozen=True)
class System:
    """The plant ``x[t+1] = A x + w``, ``y = C x + v`` (docs/theory.md)."""

    A: Matrix
    C: Matrix
    Q: Matrix | None = None
    R: Matrix | None = None
    sensors: tuple[Sensor, ...] | None = None

    @property
    def n(self) -> int:
        return len(self.A)

    @property
    def p(self) -> int:
        return len(self.C)


@dataclass(frozen=True)
class MarkovChannel:
    """A finite-state Markov packet channel of order ``nu`` (Rohr, Marelli and Fu (2014), Def. 2).

    ``table[h]`` is ``P(g_t = 1 | history h)`` where ``h`` is the integer whose
    ``nu`` bits, most significant first, are ``g[t-nu], ..., g[t-1]`` (the
    request key ``"01"`` is ``h = 1``).  Bernoulli is ``nu = 0``;
    Gilbert-Elliott is ``nu = 1`` with ``table = (q, 1 - p)``.
    """

    model: str
    order: int
    table: tuple[Fraction, ...]
    params: Mapping[str, Fraction] = field(default_factory=dict)

    def arrival(self, history: int) -> Fraction:
        """``P(g = 1 | history)``."""
        return self.table[history]

    def next_history(self, history: int, g: int) -> int:
        """History after emitting ``g`` (oldest bit dropped)."""
        if self.order == 0:
            return 0
        return ((history << 1) | g) & ((1 << self.order) - 1)

    @property
    def n_histories(self) -> int:
        return 1 << self.order

    @property
    def loss_after_losses(self) -> Fraction:
        """``P(g = 0 | nu zeros)``, the probability of another loss after ``order`` losses: Rohr, Marelli and Fu (2014), Lemma 2."""
        return 1 - self.table[0]

    @property
    def bernoulli_lambda(self) -> Fraction | None:
        """The arrival probability if the channel is i.i.d. (all entries equal)."""
        return self.table[0] if len(set(self.table)) == 1 else None

    def transition_matrix(self) -> np.ndarray:
        """Row-stochastic float matrix on histories: ``T[h, h']``."""
        k = self.n_histories
        T = np.zeros((k, k))
        for h in range(k):
            p1 = float(self.table[h])
            T[h, self.next_history(h, 1)] += p1
            T[h, self.next_history(h, 0)] += 1.0 - p1
        return T

    def stationary(self) -> np.ndarray:
        """Stationary distribution over histories (float)."""
        T = self.transition_matrix()
        k = T.shape[0]
        M = np.vstack([T.T - np.eye(k), np.ones((1, k))])
        b = np.zeros(k + 1)
        b[-1] = 1.0
        pi, *_ = np.linalg.lstsq(M, b, rcond=None)
        result: np.ndarray = np.clip(pi, 0.0, None) / np.clip(pi, 0.0, None).sum()
        return result

    def mean_arrival_rate(self) -> float:
        """Long-run fraction of packets that arrive."""
        pi = self.stationary()
        return float(sum(pi[h] * float(self.table[h]) for h in range(self.n_histories)))

    def describe(self) -> dict[str, Any]:
        """JSON-ready description (exact values as strings)."""
        from ._exact import fraction_text

        out: dict[str, Any] = {"model": self.model, "order": self.order}
        out.update({k: fraction_text(v) for k, v in self.params.items()})
        return out


@dataclass(frozen=True)
class PerSensorChannel:
    """One independent channel per sensor packet (Liu and Goldsmith (2004), generalized)."""

    channels: tuple[tuple[str, MarkovChannel], ...]

    def for_sensor(self, name: str) -> MarkovChannel:
        return dict(self.channels)[name]


Channel = Union[MarkovChannel, PerSensorChannel]


@dataclass(frozen=True)
class Packet:
    """One measurement packet: the rows of ``C`` it carries and the channel it travels over.

    Attributes
    ----------
    name:
        The sensor's name; ``None`` for a request without ``system.sensors``.
    rows:
        The rows of ``C`` (and of ``R``) in the packet.
    channel:
        Its Markov channel.
    where:
        JSON pointer of that channel in the request: ``/channel``, or
        ``/channel/channels/<name>`` for a per-sensor channel.
    """

    name: str | None
    rows: tuple[int, ...]
    channel: MarkovChannel
    where: str

    @property
    def per_sensor(self) -> bool:
        """Whether the request gives this packet a channel of its own."""
        return self.where != "/channel"


@dataclass(frozen=True)
class Request:
    """A validated request: system, channel and raw per-command options.

    ``options`` maps a command name (``"analyze"``, ``"bounds"``,
    ``"simulate"``) to its raw JSON object; each command validates its own
    object so that the contract of one command never blocks another.
    """

    system: System
    channel: Channel
    options: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    time_budget_s: float | None = None


def packets_of(request: Request) -> tuple[Packet, ...]:
    """The packets of a validated request, in ``system.sensors`` order.

    A per-sensor channel gives one packet per sensor; any other channel one
    packet with every row of ``C`` (the request's single sensor, if it names
    one).
    """
    system, ch = request.system, request.channel
    if isinstance(ch, PerSensorChannel):
        assert system.sensors is not None  # guaranteed by the validator
        return tuple(
            Packet(s.name, s.rows, ch.for_sensor(s.name), json_pointer(("channel", "channels", s.name)))
            for s in system.sensors
        )
    if system.sensors:  # then a single sensor, carrying every row
        return (Packet(system.sensors[0].name, system.sensors[0].rows, ch, "/channel"),)
    return (Packet(None, tuple(range(system.p)), ch, "/channel"),)
