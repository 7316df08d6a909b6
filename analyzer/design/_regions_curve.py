"""The exact boundary curve ``lambda_2 = h(lambda_1)`` of two Bernoulli sensors (extension of Rohr, Marelli and Fu (2014)).

With ``u_s = -log(1 - lambda_s)`` every pair (FMO block ``k``, binding blind
pattern ``F``) of :mod:`kfio.design._regions_constraints` is the half-plane
``z_1 u_1 + z_2 u_2 > K_k``, ``K_k = N_k log beta_k >= 0``.  Solved for
``lambda_2`` (when ``z_2 > 0``) it is the closed-form piece

.. math::

    \\lambda_2 > 1 - \\beta_k^{-N_k / z_2} (1 - \\lambda_1)^{-z_1 / z_2},

and a pattern with ``z_2 = 0`` (sensor 2 is never needed) is the vertical
constraint ``lambda_1 > 1 - beta_k^{-N_k / z_1}``.  The exact region is

.. math::

    \\lambda_1 > \\lambda_{1,\\min}, \\qquad \\lambda_2 > h(\\lambda_1) =
    \\max\\bigl(0, \\max_{k, F} h_{k,F}(\\lambda_1)\\bigr),

``h`` being, in ``u`` coordinates, the upper envelope of decreasing lines
(convex, piecewise linear).  The envelope is walked from ``u_1 = u_min``: at
each step the line that overtakes the current one first (the one with the
smallest crossing point among the lines of smaller slope) takes over, until a
line of slope 0 (a piece with ``z_1 = 0``, or ``h = 0``) is reached.
Breakpoints have closed forms: lines ``i`` and ``j`` cross at

.. math::

    1 - \\lambda_1 = \\beta_i^{-N_i / (z_{2,i} d)}\\, \\beta_j^{N_j / (z_{2,j} d)},
    \\qquad d = z_{1,i}/z_{2,i} - z_{1,j}/z_{2,j},

and line ``i`` meets ``h = 0`` at ``1 - lambda_1 = beta_i^{-N_i / z_{1,i}}``.

Liu and Goldsmith (2004) draws only bounds on this curve (its Figs. 4-5); the curve itself is
the Bernoulli case of docs/theory.md, "Beyond the seeds", not a theorem of
the seeds.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Sequence

import mpmath
import sympy

from .._reporting import ReportPart
from ..structure import DIGITS
from ._regions_constraints import SEPARATION, BlindPattern, BlockConstraints

LAMBDA_1 = sympy.Symbol("lambda_1")
#: Default number of samples of ``h`` on ``[0, 1]``.
DEFAULT_SAMPLES = 101
#: Float samples this close to ``lambda_1_min`` count as equal to it (samples are for drawing only).
_SAMPLE_TOL = 1e-12


@dataclass(frozen=True)
class BoundaryPiece:
    """One closed-form piece ``lambda_2 = 1 - beta^(-N/z_2) (1 - lambda_1)^(-z_1/z_2)``.

    ``z_2 = 0`` pieces are vertical: ``lambda_1 = 1 - beta^(-N/z_1)``.
    """

    block: int
    eigenvalues: tuple[str, ...]
    pattern: BlindPattern
    period: int
    beta_text: str
    formula: str
    intercept: Any  # mpf: K / z_2 (``u_2`` at ``u_1 = 0``), or K / z_1 for a vertical piece
    slope: Fraction | None  # z_1 / z_2, None for a vertical piece
    exact_base: Any = None  # beta as a SymPy expression

    @property
    def vertical(self) -> bool:
        return self.slope is None


@dataclass(frozen=True)
class Segment(ReportPart):
    """``lambda_1`` in ``(start, end)`` where one piece (or ``h = 0``) is the envelope."""

    start: float
    end: float
    start_exact: str
    end_exact: str
    piece: int | None  # index into BoundaryCurve.pieces; None: h = 0 (every lambda_2 > 0 is stable)


@dataclass(frozen=True)
class Envelope(ReportPart):
    """The envelope of a set of pieces: where the region starts and which piece is active where."""

    lambda_1_min: float | None  # None: no lambda makes it stable
    lambda_1_min_exact: str | None
    segments: tuple[Segment, ...]
    vertical: bool = False  # lambda_1_min comes from a pattern that needs only sensor 1 (strict there)


@dataclass(frozen=True)
class BoundaryCurve(ReportPart):
    """The exact boundary of the stable region of two Bernoulli sensors (extension).

    Attributes
    ----------
    axes:
        Sensor names ``(first, second)``: ``lambda_1`` is the first sensor's
        arrival probability.
    pieces:
        Every closed-form piece (binding pattern of every block).
    envelope:
        The worst block: ``lambda_1_min`` and the active piece per interval.
    per_block:
        The same envelope for each block alone (block index -> envelope).
    samples:
        ``(lambda_1, h(lambda_1))`` on a uniform grid of ``[0, 1]``; ``h`` is
        ``None`` where no ``lambda_2`` is stable (``lambda_1 < lambda_1_min``,
        or ``=`` when that bound comes from a pattern that needs sensor 1 only).
    """

    axes: tuple[str, str]
    pieces: tuple[BoundaryPiece, ...]
    envelope: Envelope
    per_block: tuple[tuple[tuple[str, ...], Envelope], ...]
    samples: tuple[tuple[float, float | None], ...]

    def h(self, lambda_1: float) -> float | None:
        """``h(lambda_1)`` as a float (``None`` where the region is empty)."""
        return _h(self.pieces, self.envelope, lambda_1)


def _pieces(blocks: Sequence[BlockConstraints]) -> list[BoundaryPiece]:
    with mpmath.workdps(DIGITS + 10):  # intercepts feed exact-looking tie tests: keep 70 digits
        return _pieces_at_precision(blocks)


def _pieces_at_precision(blocks: Sequence[BlockConstraints]) -> list[BoundaryPiece]:
    out = []
    for k, b in enumerate(blocks):
        K = b.log_beta_power()
        base = b.beta_expr if b.beta_expr is not None else sympy.Float(b.beta_float, 30)
        for p in b.patterns:
            z1, z2 = p.misses
            if z2 > 0:
                expr = 1 - base ** sympy.Rational(-b.period, z2) * (1 - LAMBDA_1) ** sympy.Rational(-z1, z2)
                formula = f"lambda_2 = {expr}"
                out.append(
                    BoundaryPiece(k, b.eigenvalues, p, b.period, b.beta_text, formula, K / z2, Fraction(z1, z2), base)
                )
            else:
                text = (
                    "no arrival pattern observes the block"
                    if z1 == 0
                    else f"lambda_1 = {1 - base ** sympy.Rational(-b.period, z1)}"
                )
                out.append(
                    BoundaryPiece(
                        k, b.eigenvalues, p, b.period, b.beta_text, text, K / z1 if z1 else mpmath.inf, None, base
                    )
                )
    return out


def _lam(u: Any) -> float:
    return 1.0 if u == mpmath.inf else float(-mpmath.expm1(-u))


def _cross_text(pi: BoundaryPiece, pj: BoundaryPiece | None) -> str:
    """Exact ``lambda_1`` where piece ``pi`` meets ``pj`` (``None``: meets ``h = 0``)."""
    assert pi.slope is not None
    zi1, zi2 = pi.pattern.misses
    if pj is None:
        return str(1 - pi.exact_base ** sympy.Rational(-pi.period, zi1))
    assert pj.slope is not None
    d = pi.slope - pj.slope
    zj2 = pj.pattern.misses[1]
    e_i = sympy.Rational(-pi.period, 1) / (zi2 * sympy.Rational(d.numerator, d.denominator))
    e_j = sympy.Rational(pj.period, 1) / (zj2 * sympy.Rational(d.numerator, d.denominator))
    return str(1 - pi.exact_base**e_i * pj.exact_base**e_j)


def envelope(pieces: Sequence[BoundaryPiece]) -> Envelope:
    """Walk the upper envelope of the (non-vertical) pieces from ``lambda_1_min``.

    Examples
    --------
    Liu and Goldsmith (2004), Case 1: one piece ``lambda_2 = 1 - 16 / (25 (1 - lambda_1))``,
    active until it meets ``h = 0`` at ``lambda_1 = 9/25``.

    >>> import mpmath
    >>> p = BoundaryPiece(0, ("5/4",), BlindPattern((), (1, 1)), 1, "25/16", "", mpmath.log(mpmath.mpf(25) / 16),
    ...                   Fraction(1), sympy.Rational(25, 16))
    >>> env = envelope([p])
    >>> [(s.start_exact, s.end_exact, s.piece) for s in env.segments]
    [('0', '9/25', 0), ('9/25', '1', None)]
    """
    with mpmath.workdps(DIGITS + 10):
        u_min, min_text = mpmath.mpf(0), "0"
        strict = any(p.vertical for p in pieces)
        for p in pieces:
            if p.vertical and p.intercept > u_min:
                u_min = p.intercept
                z1 = p.pattern.misses[0]
                min_text = "1" if z1 == 0 else str(1 - p.exact_base ** sympy.Rational(-p.period, z1))
        if u_min == mpmath.inf:
            return Envelope(None, None, (), True)
        lines = [(i, p) for i, p in enumerate(pieces) if not p.vertical]

        def value(i: int | None, u: Any) -> Any:
            if i is None:
                return mpmath.mpf(0)
            p = pieces[i]
            assert p.slope is not None
            return p.intercept - mpmath.mpf(p.slope.numerator) / p.slope.denominator * u

        def slope(i: int | None) -> Fraction:
            s = pieces[i].slope if i is not None else Fraction(0)
            assert s is not None
            return s

        candidates: list[int | None] = [i for i, _ in lines] + [None]
        # The active line at u_min: the largest value; ties go to the slowest decrease.
        cur = max(candidates, key=lambda i: (value(i, u_min), -slope(i), -1 if i is None else -i))
        segments = []
        u, u_text = u_min, min_text
        while True:
            if slope(cur) == 0:
                segments.append(Segment(_lam(u), 1.0, u_text, "1", cur))
                break
            best: tuple[Any, Fraction, int | None] | None = None
            for j in candidates:
                if slope(j) >= slope(cur):
                    continue
                s_diff = mpmath.mpf((slope(cur) - slope(j)).numerator) / (slope(cur) - slope(j)).denominator
                uj = u + (value(cur, u) - value(j, u)) / s_diff
                if uj <= u + SEPARATION:
                    uj = u  # j overtakes here: concurrent lines
                key = (uj, slope(j), j)
                if (
                    best is None
                    or (uj < best[0] - SEPARATION)
                    or (abs(uj - best[0]) <= SEPARATION and slope(j) < best[1])
                ):
                    best = key
            assert best is not None  # the floor line (slope 0) is always a candidate
            u_next, _, nxt = best
            assert cur is not None
            text = _cross_text(pieces[cur], None if nxt is None else pieces[nxt])
            if u_next > u + SEPARATION:
                segments.append(Segment(_lam(u), _lam(u_next), u_text, text, cur))
            u, u_text, cur = u_next, text, nxt
    return Envelope(_lam(u_min), min_text, tuple(segments), strict)


def _h(pieces: Sequence[BoundaryPiece], env: Envelope, lambda_1: float) -> float | None:
    if env.lambda_1_min is None or not 0 <= lambda_1 <= 1:
        return None
    if lambda_1 < env.lambda_1_min - _SAMPLE_TOL or (env.vertical and lambda_1 <= env.lambda_1_min + _SAMPLE_TOL):
        return None
    with mpmath.workdps(30):
        u = mpmath.inf if lambda_1 >= 1 else -mpmath.log1p(-mpmath.mpf(lambda_1))
        best = mpmath.mpf(0)
        for p in pieces:
            if p.vertical:
                continue
            assert p.slope is not None
            if u == mpmath.inf and p.slope != 0:
                continue
            v = p.intercept - (mpmath.mpf(p.slope.numerator) / p.slope.denominator) * (0 if p.slope == 0 else u)
            best = max(best, v)
        return float(-mpmath.expm1(-best))


def boundary_curve(
    blocks: Sequence[BlockConstraints], names: tuple[str, str], samples: int = DEFAULT_SAMPLES
) -> BoundaryCurve:
    """The exact ``lambda_2 = h(lambda_1)`` of two sensors, piece by piece and sampled.

    Parameters
    ----------
    blocks:
        The constraints of :func:`kfio.design._regions_constraints.block_constraints`
        for a two-sensor system.
    names:
        The two sensor names, in request order.
    samples:
        Number of uniform samples of ``h`` on ``[0, 1]`` (at least 2).
    """
    pieces = _pieces(blocks)
    env = envelope(pieces)
    per_block = tuple((b.eigenvalues, _reindexed(pieces, k)) for k, b in enumerate(blocks))
    xs = [i / (samples - 1) for i in range(samples)]
    pts = tuple((x, _h(pieces, env, x)) for x in xs)
    return BoundaryCurve(names, tuple(pieces), env, per_block, pts)


def _reindexed(pieces: Sequence[BoundaryPiece], block: int) -> Envelope:
    """The envelope of one block's pieces, with piece indices into the full list."""
    own = [i for i, p in enumerate(pieces) if p.block == block]
    env = envelope([pieces[i] for i in own])
    segs = tuple(
        Segment(s.start, s.end, s.start_exact, s.end_exact, None if s.piece is None else own[s.piece])
        for s in env.segments
    )
    return Envelope(env.lambda_1_min, env.lambda_1_min_exact, segs, env.vertical)


__all__ = ["BoundaryCurve", "BoundaryPiece", "Envelope", "Segment", "boundary_curve", "envelope"]
