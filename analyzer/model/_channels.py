"""Packet channels for the Python API, built by the one validator.

Each constructor writes the channel's JSON object (the ``channel`` of a
request file) and hands it to :func:`kfio.model._request.parse_markov_channel`,
so a channel made here is the one the JSON route makes from the same numbers.
:func:`channel_tree` writes a channel back as that JSON object.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from ..errors import InvalidInput
from ._coerce import Route, python_tree, renamed
from ._exact import fraction_text
from ._limits import DEFAULT_LIMITS, Limits
from ._request import parse_markov_channel
from ._types import Channel, MarkovChannel, PerSensorChannel

if TYPE_CHECKING:
    from .._typing import ChannelLike, NumberLike

_WHERE = "/channel"


def _build(tree: dict[str, Any], routes: list[Route], limits: Limits) -> MarkovChannel:
    try:
        return parse_markov_channel(tree, limits, _WHERE)
    except InvalidInput as exc:
        raise renamed(exc, routes) from None


def bernoulli(p: NumberLike, *, limits: Limits = DEFAULT_LIMITS) -> MarkovChannel:
    """I.i.d. packet arrivals with probability ``p`` (Sinopoli et al. 2004).

    ``gamma_t ~ Bernoulli(p)`` independently over time: the channel of the
    critical-probability results of Sinopoli et al. (2004), Theorem 2.

    Parameters
    ----------
    p:
        Arrival probability in ``[0, 1]``: a number, ``Fraction``, numpy
        scalar or exact string such as ``"1/2"``; a float means its shortest
        decimal text (``0.1`` is ``1/10``).

    Raises
    ------
    InvalidInput
        ``p`` is not a number or not in ``[0, 1]`` (field ``p``).

    Examples
    --------
    >>> bernoulli(0.5).table
    (Fraction(1, 2),)
    >>> bernoulli(1.5)
    Traceback (most recent call last):
    ...
    kfio.errors.InvalidInput: p: a probability must lie in [0, 1]; got 1.5
    """
    tree = {"model": "bernoulli", "arrival_probability": python_tree(p)}
    return _build(tree, [(f"{_WHERE}/arrival_probability", "p", tree["arrival_probability"], False)], limits)


def gilbert_elliott(
    *, failure_rate: NumberLike, recovery_rate: NumberLike, limits: Limits = DEFAULT_LIMITS
) -> MarkovChannel:
    """Bursty losses: a two-state Gilbert-Elliott chain (Rohr, Marelli and Fu 2014, order 1).

    ``P(lost | arrived before) = failure_rate`` and
    ``P(arrived | lost before) = recovery_rate``: a Markov channel of order 1
    with arrival table ``(recovery_rate, 1 - failure_rate)``.

    Examples
    --------
    >>> ch = gilbert_elliott(failure_rate=0.1, recovery_rate="3/5")
    >>> ch.order, ch.table
    (1, (Fraction(3, 5), Fraction(9, 10)))
    """
    tree = {"model": "gilbert_elliott", "failure_rate": python_tree(failure_rate)}
    tree["recovery_rate"] = python_tree(recovery_rate)
    routes: list[Route] = [(f"{_WHERE}/{k}", k, tree[k], False) for k in ("failure_rate", "recovery_rate")]
    return _build(tree, routes, limits)


def markov(
    arrival_probability: Mapping[str, NumberLike], *, order: int | None = None, limits: Limits = DEFAULT_LIMITS
) -> MarkovChannel:
    """A Markov packet channel of order ``nu`` (Rohr, Marelli and Fu 2014, Definition 2).

    Parameters
    ----------
    arrival_probability:
        ``{history: P(arrival | history)}`` for all ``2^nu`` histories; a
        history is ``nu`` characters of ``0``/``1``, oldest first (``"01"``:
        lost two steps ago, arrived one step ago).
    order:
        ``nu``; by default the length of the keys.

    Examples
    --------
    >>> markov({"0": 0.6, "1": 0.9}).table
    (Fraction(3, 5), Fraction(9, 10))
    >>> markov({"0": 0.6, "11": 0.9})
    Traceback (most recent call last):
    ...
    kfio.errors.InvalidInput: arrival_probability['11']: a history key must be 1 characters of 0/1 (oldest first)
    """
    if not isinstance(arrival_probability, Mapping):
        raise InvalidInput("arrival_probability", 'expected a mapping of histories such as "01" to probabilities')
    if order is None:
        order = len(next(iter(arrival_probability), ""))
    tree = {"model": "markov", "order": python_tree(order), "arrival_probability": python_tree(arrival_probability)}
    routes: list[Route] = [(f"{_WHERE}/{k}", k, tree[k], False) for k in ("order", "arrival_probability")]
    return _build(tree, routes, limits)


def per_sensor(
    channels: Mapping[str, ChannelLike | NumberLike], *, limits: Limits = DEFAULT_LIMITS
) -> PerSensorChannel:
    """One independent channel per sensor packet (``System(..., sensors=...)``).

    Parameters
    ----------
    channels:
        ``{sensor name: channel}``; a channel is one of :func:`bernoulli`,
        :func:`gilbert_elliott`, :func:`markov`, its JSON object, or a number
        (shorthand for ``bernoulli(number)``).  Which names the system has is
        checked when the channel meets the system (``kfio.analyze`` and
        friends).

    Examples
    --------
    >>> ch = per_sensor({"gps": 0.5, "imu": gilbert_elliott(failure_rate=0.1, recovery_rate=0.5)})
    >>> [(name, c.model) for name, c in ch.channels]
    [('gps', 'bernoulli'), ('imu', 'gilbert_elliott')]
    """
    if not isinstance(channels, Mapping) or not channels:
        raise InvalidInput("channels", "expected a non-empty mapping of sensor names to channels")
    out = []
    for name, ch in channels.items():
        if not isinstance(name, str):
            raise InvalidInput("channels", f"sensor names must be strings; got {name!r}")
        tree = channel_tree(ch, bernoulli_number=True)
        if not isinstance(tree, dict) or tree.get("model") == "per_sensor":
            raise InvalidInput(
                f"channels[{name!r}]", "expected a one-packet channel (bernoulli, gilbert_elliott, markov)"
            )
        out.append((name, _build(tree, [(_WHERE, f"channels[{name!r}]", tree, False)], limits)))
    return PerSensorChannel(tuple(out))


def channel_tree(channel: Any, bernoulli_number: bool = False) -> Any:
    """The JSON object of a channel (a :class:`MarkovChannel`, :class:`PerSensorChannel` or mapping).

    Exact values are written as their fraction text, which the validator reads
    back to the same rationals.

    Examples
    --------
    >>> channel_tree(gilbert_elliott(failure_rate=0.1, recovery_rate=0.6))
    {'model': 'gilbert_elliott', 'failure_rate': '1/10', 'recovery_rate': '3/5'}
    """
    if isinstance(channel, PerSensorChannel):
        return {"model": "per_sensor", "channels": {name: channel_tree(c) for name, c in channel.channels}}
    if isinstance(channel, MarkovChannel):
        if channel.model == "bernoulli":
            return {"model": "bernoulli", "arrival_probability": fraction_text(channel.table[0])}
        if channel.model == "gilbert_elliott":
            return {
                "model": "gilbert_elliott",
                "failure_rate": fraction_text(1 - channel.table[1]),
                "recovery_rate": fraction_text(channel.table[0]),
            }
        nu = channel.order
        return {
            "model": "markov",
            "order": nu,
            "arrival_probability": {
                format(h, f"0{nu}b") if nu else "": fraction_text(x) for h, x in enumerate(channel.table)
            },
        }
    if isinstance(channel, Mapping):
        return python_tree(channel)
    if bernoulli_number and not isinstance(channel, (list, tuple)):
        return {"model": "bernoulli", "arrival_probability": python_tree(channel)}
    return channel  # the validator says what it expected


__all__ = ["Channel", "bernoulli", "channel_tree", "gilbert_elliott", "markov", "per_sensor"]
