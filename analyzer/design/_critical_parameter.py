"""The exact critical value of one channel parameter, the others fixed, for Markov channels of any order.

The request names the parameter by a JSON pointer into ``channel``
(``options.analyze.critical_parameter``):

=====================================  ============================================
``/channel/arrival_probability``       Bernoulli ``lambda``
``/channel/recovery_rate``             Gilbert-Elliott ``q`` (``table[0]``)
``/channel/failure_rate``              Gilbert-Elliott ``p`` (``table[1] = 1 - p``)
``/channel/arrival_probability/01``    Markov ``P(g_t = 1 | history 01)``
``/channel/channels/<name>/...``       the same inside one sensor's channel
=====================================  ============================================

With ``x`` the parameter, every entry of the one-period transfer matrix
``P_F(x)`` of a blind set ``F`` is a polynomial in ``x`` over ``Q``, so a
block's rate crosses 1 only where ``det(beta^(-N) I - P_F(x)) = 0`` for some
maximal blind set ``F`` (Theorem 1 of Rohr, Marelli and Fu, 2014, with
``sigma^N = max_F rho(P_F)``).  The real roots of these polynomials in
``(0, 1)`` are the candidates, and the labels between them are decided exactly
at rational points by the Sturm-sequence comparison of
:func:`kfio.sigma._decide.compare_rate_markov`
(:mod:`kfio.design._line`).  Exact for rational ``|alpha_k|^2``; otherwise
the report says ``exact: false`` and gives no critical value.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from fractions import Fraction
from typing import Any, Sequence

import sympy
from sympy.polys.matrices import DomainMatrix

from .._budget import Budget
from .._reporting import ReportPart
from ..errors import InvalidInput
from ..model import MarkovChannel, PerSensorChannel, Request, pointer_tokens, value_text
from ..search import Margins, SlotSpace, search
from ..sigma import SigmaResult, compare_rate_markov, period_transfer_matrix
from ..structure import FmoBlock
from ._line import Change, add_candidates, critical_text, roots_in_unit, scan

X_SYM = sympy.Symbol("x")
_SIGN = {-1: "stable", 0: "boundary", 1: "unstable"}


@dataclass(frozen=True)
class Parameter:
    """Where the parameter sits: channel index, table entries set to ``x`` or ``1 - x``."""

    pointer: str
    group: int
    entries: tuple[int, ...]
    complement: bool
    value: Fraction

    def channels(self, base: Sequence[MarkovChannel], x: Fraction) -> list[MarkovChannel]:
        out = list(base)
        ch = out[self.group]
        table = list(ch.table)
        for e in self.entries:
            table[e] = 1 - x if self.complement else x
        out[self.group] = replace(ch, table=tuple(table))
        return out


def parse_parameter(request: Request, pointer: str) -> Parameter:
    """Resolve ``options.analyze.critical_parameter`` against the request's channel.

    Raises
    ------
    InvalidInput
        Naming ``/options/analyze/critical_parameter``: a pointer that names no
        probability of the channel.
    """
    where = "/options/analyze/critical_parameter"
    ch = request.channel
    parts = pointer.split("/")
    if parts[:2] != ["", "channel"]:
        raise InvalidInput(
            where, "critical_parameter must be a JSON pointer into channel, such as /channel/recovery_rate"
        )
    rest = pointer_tokens(pointer)[1:]
    group = 0
    if isinstance(ch, PerSensorChannel):
        names = [n for n, _ in ch.channels]
        if len(rest) < 2 or rest[0] != "channels" or rest[1] not in names:
            raise InvalidInput(
                where, f"with per_sensor channels the pointer starts /channel/channels/<sensor>, sensors {names}"
            )
        group, chan, rest = names.index(rest[1]), ch.channels[names.index(rest[1])][1], rest[2:]
    else:
        chan = ch
    found = channel_parameter(chan, rest)
    if found is None:
        raise InvalidInput(
            where, f"{value_text(pointer, 80)} names no arrival probability of this {chan.model} channel"
        )
    entries, complement, value = found
    return Parameter(pointer, group, entries, complement, value)


def channel_parameter(chan: MarkovChannel, rest: Sequence[str]) -> tuple[tuple[int, ...], bool, Fraction] | None:
    """The entries of ``chan.table`` that the pointer tokens ``rest`` name, set to ``x`` or ``1 - x``.

    ``(entries, complement, value)``: the table entries that become ``1 - x`` (``complement``)
    or ``x``, and the channel's present value of the parameter; ``None`` when ``rest``
    (``["recovery_rate"]``, ``["arrival_probability", "01"]``, ...) names no probability of
    ``chan`` (the table of the module docstring).
    """
    rest = list(rest)
    if chan.model == "bernoulli" and rest == ["arrival_probability"]:
        return (0,), False, chan.table[0]
    if chan.model == "gilbert_elliott" and rest == ["recovery_rate"]:
        return (0,), False, chan.table[0]
    if chan.model == "gilbert_elliott" and rest == ["failure_rate"]:
        return (1,), True, 1 - chan.table[1]
    if chan.model == "markov" and len(rest) == 2 and rest[0] == "arrival_probability":
        key = rest[1]
        if len(key) == chan.order and all(c in "01" for c in key):
            h = int(key, 2) if chan.order else 0
            return (h,), False, chan.table[h]
    return None


def _symbolic_group_matrix(channel: MarkovChannel, period: int, phases: set[int], param: Parameter | None) -> Any:
    """One group's period matrix with entries polynomial in ``x`` (``param`` on this group) or rational."""
    k = channel.n_histories

    def prob(h: int) -> Any:
        if param is not None and h in param.entries:
            return 1 - X_SYM if param.complement else X_SYM
        t = channel.table[h]
        return sympy.Rational(t.numerator, t.denominator)

    prod = sympy.eye(k)
    for n in range(period):
        step = sympy.zeros(k, k)
        for h in range(k):
            p1 = prob(h)
            step[h, channel.next_history(h, 0)] += 1 - p1
            if n in phases:
                step[h, channel.next_history(h, 1)] += p1
        prod = (prod * step).applyfunc(sympy.expand)
    return prod


def _boundary_poly(
    beta: Fraction, N: int, F: frozenset[tuple[int, int]], channels: Sequence[MarkovChannel], param: Parameter
) -> Any:
    """``det(beta^(-N) I - P_F(x))`` as a polynomial in ``x``."""
    M = sympy.Matrix([[1]])
    for g, ch in enumerate(channels):
        phases = {n % N for n, grp in F if grp == g}
        G = _symbolic_group_matrix(ch, N, phases, param if g == param.group else None)
        M = sympy.kronecker_product(M, G)
    c = sympy.Rational(beta.denominator**N, beta.numerator**N)
    K = M.shape[0]
    dm = DomainMatrix.from_Matrix(c * sympy.eye(K) - M).convert_to(sympy.QQ[X_SYM])
    return dm.domain.to_sympy(dm.det())


@dataclass(frozen=True)
class ParameterConstraint(ReportPart):
    block: int
    eigenvalues: tuple[str, ...]
    beta: Any
    beta_float: float
    period: int
    blind_set: frozenset[tuple[int, int]]


def _constraints(
    items: Sequence[tuple[FmoBlock, SigmaResult | None]], n_groups: int, budget: Budget
) -> list[ParameterConstraint]:
    out: list[ParameterConstraint] = []
    for i, (block, res) in enumerate(items):
        if res is None:
            continue
        N = res.period
        base: dict[str, Any] = dict(
            block=i, eigenvalues=block.eigenvalue_texts, beta=block.modulus_sq, beta_float=block.modulus_sq_float
        )
        if res.fully_blind:
            sets: Sequence[frozenset[tuple[int, int]]] = [frozenset((n, g) for n in range(N) for g in range(n_groups))]
        elif n_groups == 1 and not res.degenerate:
            sets = [frozenset()]
        elif res.maximal_blind_sets:
            sets = res.maximal_blind_sets
        else:
            assert block.phase is not None
            space = SlotSpace.from_block(block.phase)
            masks = search(space, budget, Margins(space.tol)).maximal
            reps = N // space.n_phases
            sets = [
                frozenset((n + k * space.n_phases, g) for n, g in space.slots(m) for k in range(reps)) for m in masks
            ]
        out.extend(ParameterConstraint(period=N, blind_set=F, **base) for F in sets)
    return out


@dataclass(frozen=True)
class CriticalParameter(ReportPart):
    """The verdict along one channel parameter ``x`` in ``(0, 1)``, the others fixed.

    Attributes
    ----------
    pointer, value:
        The parameter and its value in the request.
    intervals:
        ``(lower, upper, label)`` covering ``(0, 1)``, labels exact.
    crossings:
        Where the label changes, with the deciding block and blind set.
    exact:
        Every ``|alpha_k|^2`` was rational: candidates are exact algebraic numbers.
    basis:
        ``"theorem"`` for one packet, ``"extension"`` with per-sensor channels.
    """

    pointer: str
    value: Fraction
    intervals: tuple[tuple[float, float, str], ...]
    crossings: tuple[Change[ParameterConstraint], ...]
    exact: bool
    basis: str

    def summary_lines(self) -> list[str]:
        if not self.crossings:
            return [f"critical value of {self.pointer}: none ({self.intervals[0][2]} on all of (0, 1))"]
        parts = ", ".join(f"{critical_text(c.exact_text, c.value)} [{c.left} below]" for c in self.crossings)
        return [f"critical value of {self.pointer}: {parts}  [{self.basis}]"]


def critical_parameter(
    request: Request,
    pointer: str,
    items: Sequence[tuple[FmoBlock, SigmaResult | None]],
    channels: Sequence[MarkovChannel],
    budget: Budget,
) -> CriticalParameter:
    """The exact critical value(s) of the parameter at ``pointer`` (Theorem 1 on a one-parameter family).

    Examples
    --------
    Rohr, Marelli and Fu (2014)'s degenerate pair ``(5/4) diag(1, -1)``, ``C = [1 1]`` over a
    Gilbert-Elliott channel: at ``q = 1/2`` the failure rate must stay below
    ``2 (256/625 - 1/4) = 399/1250``.

    >>> from kfio import load_request, analyze
    >>> r = analyze(load_request('{"system": {"A": [["5/4", 0], [0, "-5/4"]], "C": [[1, 1]]}, '
    ...     '"channel": {"model": "gilbert_elliott", "failure_rate": "1/4", "recovery_rate": "1/2"}, '
    ...     '"options": {"analyze": {"critical_parameter": "/channel/failure_rate"}}}'))
    >>> r.critical_parameter.crossings[0].exact_text
    '399/1250'
    """
    param = parse_parameter(request, pointer)
    cons = _constraints(items, len(channels), budget)
    exact = all(c.beta is not None and c.beta.is_rational for c in cons)
    candidates: list[Any] = []
    if exact:
        for c in cons:
            budget.tick("critical parameter: boundary polynomials")
            poly = _boundary_poly(c.beta.rational, c.period, c.blind_set, channels, param)
            add_candidates(candidates, roots_in_unit(poly, X_SYM), c)

    def label_at(x: Fraction) -> tuple[str, ParameterConstraint | None]:
        chans = param.channels(channels, x)
        best, where = -2, None
        for c in cons:
            s, _ = compare_rate_markov(
                c.beta, c.beta_float, c.period, period_transfer_matrix(c.period, c.blind_set, chans)
            )
            if s > best:
                best, where = s, c
        return (_SIGN[best] if where is not None else "stable"), where

    intervals, changes = scan(candidates, label_at)
    return CriticalParameter(
        pointer=pointer,
        value=param.value,
        intervals=intervals,
        crossings=changes if exact else (),
        exact=exact,
        basis="extension" if len(channels) > 1 else "theorem",
    )


__all__ = ["CriticalParameter", "Parameter", "channel_parameter", "critical_parameter", "parse_parameter"]
