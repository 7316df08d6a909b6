"""The closed loop as a Markov jump linear system (Costa, Fragoso and Marques 2005, Ch. 3).

Every packet link is a finite Markov chain whose state fixes whether the
packet sent at time ``t`` arrives:

* a Bernoulli link (i.i.d., order 0) has states ``g in {0, 1}``;
* a Markov link of order ``nu >= 1`` (Gilbert-Elliott is ``nu = 1``) has as
  state the ``nu`` most recent arrivals ``(g[t-nu+1], ..., g[t])``, so its
  transition from ``r`` to ``next(r, g)`` has probability ``P(g | r)`` and
  the packet at time ``t`` arrived iff the last bit of ``r`` is 1.

The links are independent, so the joint chain is their product.  The loop
state ``z = (x, x_hat[t|t-1])`` (and the held inputs for ``on_loss: hold``)
obeys ``z[t+1] = M(theta[t]) z[t] + G(theta[t]) n[t]`` with ``n = (w, v)``,
``theta`` the joint state (Schenato, Sinopoli, Franceschetti, Poolla and
Sastry 2007, Sec. II, with fixed linear gains).

I.i.d. links average out: with ``q(g)`` their arrival law, the mode-wise
second moments are ``E[z z' 1{theta = (g, r)}] = q(g) Y_r`` where ``r`` is the
state of the links with memory, and ``Y`` follows the operator with the
averaged modes ``sum_g q(g) M_(g,r) . M_(g,r)'`` (its non-zero spectrum is
that of the full operator).  So a loop whose links are all Bernoulli has one
mode, and the operator's size is ``d (d + 1) / 2`` with ``d`` the state size.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from fractions import Fraction
from typing import Sequence

import flint

from ..errors import InvalidInput
from ..model import MarkovChannel, Matrix, Request, packets_of
from ._model import LoopRequest


def qmat(m: Matrix | Sequence[Sequence[Fraction]]) -> flint.fmpq_mat:
    """A matrix of Fractions as a flint ``fmpq_mat``, exactly."""
    rows, cols = len(m), len(m[0]) if m else 0
    return flint.fmpq_mat(rows, cols, [flint.fmpq(x.numerator, x.denominator) for row in m for x in row])


def eye(k: int) -> flint.fmpq_mat:
    out = flint.fmpq_mat(k, k)
    for i in range(k):
        out[i, i] = 1
    return out


def hstack(*blocks: flint.fmpq_mat) -> flint.fmpq_mat:
    rows = blocks[0].nrows()
    out = flint.fmpq_mat(rows, sum(b.ncols() for b in blocks))
    c0 = 0
    for b in blocks:
        for i in range(rows):
            for j in range(b.ncols()):
                out[i, c0 + j] = b[i, j]
        c0 += b.ncols()
    return out


def vstack(*blocks: flint.fmpq_mat) -> flint.fmpq_mat:
    return hstack(*(b.transpose() for b in blocks)).transpose()


def columns(m: flint.fmpq_mat, start: int, stop: int) -> flint.fmpq_mat:
    out = flint.fmpq_mat(m.nrows(), stop - start)
    for i in range(m.nrows()):
        for j in range(start, stop):
            out[i, j - start] = m[i, j]
    return out


@dataclass(frozen=True)
class Link:
    """One packet link as a Markov chain: ``P[r][r']``, and whether the packet of state ``r`` arrived."""

    label: str
    pointer: str
    channel: MarkovChannel
    P: tuple[tuple[Fraction, ...], ...]
    arrived: tuple[int, ...]

    @property
    def iid(self) -> bool:
        return self.channel.order == 0

    @property
    def states(self) -> int:
        return len(self.arrived)


def link_of(label: str, pointer: str, ch: MarkovChannel) -> Link:
    """The chain of one channel (see the module docstring)."""
    if ch.order == 0:
        lam = ch.table[0]
        row = (1 - lam, lam)
        return Link(label, pointer, ch, (row, row), (0, 1))
    k = ch.n_histories
    P = [[Fraction(0)] * k for _ in range(k)]
    for r in range(k):
        P[r][ch.next_history(r, 1)] += ch.table[r]
        P[r][ch.next_history(r, 0)] += 1 - ch.table[r]
    return Link(label, pointer, ch, tuple(tuple(row) for row in P), tuple(r & 1 for r in range(k)))


def stationary(link: Link) -> tuple[Fraction, ...]:
    """The stationary law of one link's chain, exactly; refused when it is not unique."""
    k = link.states
    M = flint.fmpq_mat(k, k)
    for i in range(k):
        for j in range(k):
            x = link.P[i][j] - (1 if i == j else 0)
            M[j, i] = flint.fmpq(x.numerator, x.denominator)
    for i in range(k):
        M[k - 1, i] = 1
    rhs = flint.fmpq_mat(k, 1)
    rhs[k - 1, 0] = 1
    try:
        sol = M.solve(rhs)
    except ZeroDivisionError:
        raise InvalidInput(
            link.pointer,
            "the channel's Markov chain has more than one stationary law (some state is never left and "
            "another never reached); the loop's long-run cost is not defined for it",
        ) from None
    return tuple(Fraction(int(sol[i, 0].p), int(sol[i, 0].q)) for i in range(k))


def mean_arrival(link: Link) -> Fraction:
    """Long-run fraction of the link's packets that arrive, exactly."""
    return sum((w for w, g in zip(stationary(link), link.arrived) if g), Fraction(0))


@dataclass(frozen=True)
class Branch:
    """One arrival pattern of the i.i.d. links inside a reduced mode: weight and the exact maps.

    ``[M | G]`` maps ``(z, n)`` to ``z[t+1]``; ``[Fa | Ea]`` to the applied input ``a[t]``.
    """

    weight: Fraction
    M: flint.fmpq_mat
    G: flint.fmpq_mat
    Fa: flint.fmpq_mat
    Ea: flint.fmpq_mat


@dataclass(frozen=True)
class Mjls:
    """The reduced Markov jump linear system: modes of the links with memory, i.i.d. links averaged.

    ``P[i][j]`` is the transition probability between reduced modes, ``pi``
    their stationary law, ``branches[i]`` the averaged patterns of mode ``i``.
    ``Sigma`` is the covariance of ``n = (w, v)``; ``Wz`` weighs ``z`` in the
    stage cost and ``U`` the applied input.
    """

    d: int
    links: tuple[Link, ...]
    P: tuple[tuple[Fraction, ...], ...]
    pi: tuple[Fraction, ...]
    branches: tuple[tuple[Branch, ...], ...]
    Sigma: flint.fmpq_mat
    Wz: flint.fmpq_mat
    U: flint.fmpq_mat

    @property
    def modes(self) -> int:
        return len(self.P)


def sensor_links(req: LoopRequest) -> list[tuple[Link, tuple[int, ...]]]:
    """The sensor packets' links and the rows of ``C`` each carries."""
    packets = packets_of(Request(system=req.system, channel=req.channel))
    return [(link_of(pk.name or "sensor", pk.where, pk.channel), pk.rows) for pk in packets]


def _reduced(links: Sequence[Link]) -> tuple[list[tuple[int, ...]], list[list[Fraction]], list[Fraction]]:
    """Reduced modes (states of the links with memory), their transitions and stationary law."""
    mem = [lk for lk in links if not lk.iid]
    modes = list(itertools.product(*(range(lk.states) for lk in mem)))
    pis = [stationary(lk) for lk in mem]
    P, pi = [], []
    for a in modes:
        row = []
        for b in modes:
            w = Fraction(1)
            for lk, i, j in zip(mem, a, b):
                w *= lk.P[i][j]
            row.append(w)
        P.append(row)
        w = Fraction(1)
        for s, i in zip(pis, a):
            w *= s[i]
        pi.append(w)
    return modes, P, pi


def _patterns(links: Sequence[Link], mode: tuple[int, ...]) -> list[tuple[Fraction, dict[int, int]]]:
    """Arrival of every link (by index) for each pattern of the i.i.d. links, with its probability."""
    mem_idx = [i for i, lk in enumerate(links) if not lk.iid]
    iid_idx = [i for i, lk in enumerate(links) if lk.iid]
    fixed = {i: links[i].arrived[s] for i, s in zip(mem_idx, mode)}
    out = []
    for gs in itertools.product((0, 1), repeat=len(iid_idx)):
        w = Fraction(1)
        arr = dict(fixed)
        for i, g in zip(iid_idx, gs):
            lam = links[i].channel.table[0]
            w *= lam if g else 1 - lam
            arr[i] = g
        if w:
            out.append((w, arr))
    return out


def _diag(values: Sequence[int]) -> flint.fmpq_mat:
    out = flint.fmpq_mat(len(values), len(values))
    for i, v in enumerate(values):
        out[i, i] = v
    return out


def loop_state_size(req: LoopRequest) -> int:
    """``2n``, plus ``m`` for the held input (``on_loss: hold``), plus ``m`` for UDP's belief of it."""
    d = 2 * req.n
    if req.on_loss == "hold":
        d += req.m * (2 if req.protocol == "udp" else 1)
    return d


def loop_maps(req: LoopRequest, gamma: Sequence[int], nu: int, nubar: Fraction) -> tuple[flint.fmpq_mat, ...]:
    """``(M, G, Fa, Ea)`` of one arrival pattern: rows of ``C`` that arrived (``gamma``) and the actuator's ``nu``.

    Columns are ``(z, w, v)``.  The estimator's idea of the applied input is
    ``a`` itself for TCP-like protocols (acknowledged) and, for UDP-like ones,
    ``nubar u`` (``on_loss: zero``) or ``nubar u + (1 - nubar) a_hat[t-1]``
    (``hold``), ``nubar`` the actuator link's long-run arrival rate.
    """
    n, m, p = req.n, req.m, req.p
    d = loop_state_size(req)
    width = d + n + p
    A, B, C, K, L = (qmat(x) for x in (req.system.A, req.B, req.system.C, req.estimator, req.feedback))

    def sel(start: int, size: int) -> flint.fmpq_mat:
        out = flint.fmpq_mat(size, width)
        for i in range(size):
            out[i, start + i] = 1
        return out

    X, XH = sel(0, n), sel(n, n)
    Wn, Vn = sel(d, n), sel(d + n, p)
    innov = _diag(gamma) * (C * X + Vn - C * XH)
    XF = XH + K * innov if req.form == "filter" else XH
    Uc = -(L * XF)
    held = req.on_loss == "hold"
    a_prev = sel(2 * n, m) if held else None
    applied = nu * Uc + ((1 - nu) * a_prev if a_prev is not None else 0 * Uc)
    nb = flint.fmpq(nubar.numerator, nubar.denominator)
    if req.protocol == "tcp":
        believed = applied
    elif held:
        believed = nb * Uc + (1 - nb) * sel(2 * n + m, m)
    else:
        believed = nb * Uc
    x_next = A * X + B * applied + Wn
    if req.form == "filter":
        xh_next = A * XF + B * believed
    else:
        xh_next = A * XH + B * believed + K * innov
    blocks = [x_next, xh_next]
    if held:
        blocks.append(applied)
        if req.protocol == "udp":
            blocks.append(believed)
    full = vstack(*blocks)
    return columns(full, 0, d), columns(full, d, width), columns(applied, 0, d), columns(applied, d, width)


def _noise(req: LoopRequest) -> flint.fmpq_mat:
    n, p = req.n, req.p
    S = flint.fmpq_mat(n + p, n + p)
    assert req.system.Q is not None and req.system.R is not None  # required by the loop validator
    Q, R = qmat(req.system.Q), qmat(req.system.R)
    for i in range(n):
        for j in range(n):
            S[i, j] = Q[i, j]
    for i in range(p):
        for j in range(p):
            S[n + i, n + j] = R[i, j]
    return S


def loop_mjls(req: LoopRequest, overrides: dict[str, MarkovChannel] | None = None) -> Mjls:
    """The reduced MJLS of the closed loop; ``overrides`` replaces the channel of a link (by pointer)."""
    overrides = overrides or {}
    sensors = sensor_links(req)
    links = [link_of(lk.label, lk.pointer, overrides.get(lk.pointer, lk.channel)) for lk, _ in sensors]
    act_ch = overrides.get("/actuator_channel", req.actuator)
    links.append(link_of("actuator", "/actuator_channel", act_ch))
    rows_of = [rows for _, rows in sensors]
    # nubar is part of the estimator's design: the rate of the request's actuator link, also when a
    # critical value varies the link (so the operator stays affine in the link's parameter)
    nubar = (
        mean_arrival(link_of("actuator", "/actuator_channel", req.actuator)) if req.protocol == "udp" else Fraction(1)
    )
    modes, P, pi = _reduced(links)
    cache: dict[tuple[tuple[int, ...], int], tuple[flint.fmpq_mat, ...]] = {}
    branches = []
    for mode in modes:
        out = []
        for w, arr in _patterns(links, mode):
            gamma = [0] * req.p
            for k, rows in enumerate(rows_of):
                for r in rows:
                    gamma[r] = arr[k]
            key = (tuple(gamma), arr[len(links) - 1])
            if key not in cache:
                cache[key] = loop_maps(req, key[0], key[1], nubar)
            M, G, Fa, Ea = cache[key]
            out.append(Branch(w, M, G, Fa, Ea))
        branches.append(tuple(out))
    d = loop_state_size(req)
    Wz = flint.fmpq_mat(d, d)
    Wq = qmat(req.W)
    for i in range(req.n):
        for j in range(req.n):
            Wz[i, j] = Wq[i, j]
    return Mjls(
        d,
        tuple(links),
        tuple(map(tuple, P)),
        tuple(pi),
        tuple(branches),
        _noise(req),
        Wz,
        qmat(req.U),
    )


def estimator_mjls(req: LoopRequest, overrides: dict[str, MarkovChannel] | None = None) -> Mjls:
    """The estimation error ``e = x - x_hat[t|t-1]`` of the fixed gain alone (no control, no actuator link).

    Predictor form: ``e[t+1] = (A - K Gamma C) e + w - K Gamma v``; filter form:
    ``e[t+1] = A (I - K Gamma C) e + w - A K Gamma v``, ``Gamma`` the rows that
    arrived.  The stage cost is ``e' e`` (its trace).
    """
    overrides = overrides or {}
    sensors = sensor_links(req)
    links = [link_of(lk.label, lk.pointer, overrides.get(lk.pointer, lk.channel)) for lk, _ in sensors]
    rows_of = [rows for _, rows in sensors]
    n, p = req.n, req.p
    A, C, K = qmat(req.system.A), qmat(req.system.C), qmat(req.estimator)
    modes, P, pi = _reduced(links)
    zero_a = flint.fmpq_mat(0, n)
    zero_e = flint.fmpq_mat(0, n + p)
    branches = []
    for mode in modes:
        out = []
        for w, arr in _patterns(links, mode):
            gamma = [0] * p
            for k, rows in enumerate(rows_of):
                for r in rows:
                    gamma[r] = arr[k]
            KG = K * _diag(gamma)
            if req.form == "filter":
                M = A * (eye(n) - KG * C)
                G = hstack(eye(n), -(A * KG))
            else:
                M = A - KG * C
                G = hstack(eye(n), -KG)
            out.append(Branch(w, M, G, zero_a, zero_e))
        branches.append(tuple(out))
    return Mjls(n, tuple(links), tuple(map(tuple, P)), tuple(pi), tuple(branches), _noise(req), eye(n), eye(0))


__all__ = [
    "Branch",
    "Link",
    "Mjls",
    "estimator_mjls",
    "link_of",
    "loop_maps",
    "loop_mjls",
    "loop_state_size",
    "mean_arrival",
    "qmat",
    "stationary",
]
