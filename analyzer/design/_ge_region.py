"""The exact stability region of a Gilbert-Elliott channel in the (p, q) square.

Failure rate ``p = P(lost | arrived)``, recovery rate ``q = P(arrived | lost)``.
For an FMO block with ``beta = |alpha|^2`` and period ``N``, Theorem 1 of Rohr,
Marelli and Fu (2014) gives the rate ``beta sigma(p, q)`` with ``sigma^N =
max_F rho(P_F)`` over the maximal blind sets ``F``.  After a loss the channel
state is known, so (renewal argument, :class:`kfio.sigma._sigma._RenewalScore`)

.. math::

    \\rho(P_F) = \\prod_{m \\text{ missed}} u_{a_m + 1}(p, q), \\qquad
    u_1 = 1 - q, \\quad u_{k+1} = p + (1 - p - q)\\, u_k ,

``u_k = P(lost at t + k | lost at t)`` and ``a_m`` the phases allowed between
missed phase ``m`` and the next one.  Every ``u_k`` is a polynomial in ``p, q``,
so each pattern's boundary ``beta^N prod_m u_{a_m+1}(p, q) = 1`` is an algebraic
curve, and the stable region is the intersection over blocks and patterns of
``beta^N prod_m u_{a_m+1} < 1``.  Wu, Shi, Anderson and Johansson (2018) prove
that a critical curve exists; this module computes it.

* non-degenerate block: the only blind set is empty, ``rho = (1 - q)^N``: the
  line ``beta (1 - q) = 1`` (You, Fu and Xie, 2011);
* ``alpha diag(1, -1)``, ``C = [1 1]``: ``beta^2 ((1 - q)^2 + p q) = 1``.

Labels are exact (rational arithmetic at rational points), critical values are
exact real algebraic numbers (``CRootOf``) where ``beta`` is rational.  The
construction is Theorem 1 evaluated on a family of channels (label
``theorem``); the closed form of ``rho(P_F)`` is checked against the exact
transfer matrices and the brute-force blind-probability DP in the tests.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Callable, Sequence

import mpmath
import numpy as np
import sympy

from .._budget import Budget
from .._reporting import ReportPart
from ..model import MarkovChannel
from ..search import Margins, SlotSpace, search
from ..sigma import SigmaResult
from ..structure import FmoBlock, readable
from ._line import Candidate, add_candidates, critical_text, roots_in_unit, scan

P_SYM, Q_SYM = sympy.symbols("p q")
LABELS = ("stable", "boundary", "unstable")
_SIGN = {-1: "stable", 0: "boundary", 1: "unstable"}


def _same(x: Any) -> Any:
    return x


def _u(k: int, p: Any, q: Any, tidy: Callable[[Any], Any] = _same) -> Any:
    """``u_k(p, q) = P(lost at t + k | lost at t)``: ``u_1 = 1 - q``, ``u_{k+1} = p + (1 - p - q) u_k``.

    The one definition of the recurrence, for every number type kfio evaluates
    it in: :class:`~fractions.Fraction` (exact labels), NumPy float arrays (the
    drawn curve) and SymPy symbols (boundary polynomials, ``tidy=sympy.expand``).
    """
    u = tidy(1 - q)
    for _ in range(k - 1):
        u = tidy(p + (1 - p - q) * u)
    return u


def _rho(gaps: Sequence[int], p: Any, q: Any, one: Any, tidy: Callable[[Any], Any] = _same) -> Any:
    """``rho(P_F) = prod_m u_{a_m + 1}(p, q)`` starting from ``one`` (``Fraction(1)``, an array of ones, ``1``)."""
    out = one
    for a in gaps:
        out = tidy(out * _u(a + 1, p, q, tidy))
    return out


@dataclass(frozen=True)
class GePattern:
    """One maximal blind set of one block, as the gaps between its missed phases.

    Attributes
    ----------
    block:
        Index of the block in the report.
    eigenvalues:
        Exact texts of the block's eigenvalues.
    period:
        ``N``.
    allowed:
        Phases in ``[0, N)`` at which an arrival keeps the block blind (the
        blind set ``F``).
    gaps:
        ``a_m`` for every missed phase ``m`` (``()`` for a fully blind block:
        ``rho = 1``).
    beta, beta_float:
        ``|alpha|^2`` exactly (an :class:`~kfio.structure._algebraic.AlgebraicReal`) and as a float.
    """

    block: int
    eigenvalues: tuple[str, ...]
    period: int
    allowed: tuple[int, ...]
    gaps: tuple[int, ...]
    beta: Any
    beta_float: float

    def rho(self, p: Fraction, q: Fraction) -> Fraction:
        """``rho(P_F) = prod_m u_{a_m+1}(p, q)``, exactly."""
        rho: Fraction = _rho(self.gaps, p, q, Fraction(1))
        return rho

    def rho_float(self, p: np.ndarray, q: np.ndarray) -> np.ndarray:
        """:meth:`rho` in floating point (the same recurrence on NumPy arrays), for drawing."""
        p, q = np.asarray(p, dtype=float), np.asarray(q, dtype=float)
        out: np.ndarray = _rho(self.gaps, p, q, np.ones(np.broadcast(p, q).shape))
        return out

    def rho_expr(self) -> Any:
        """:meth:`rho` as a polynomial in the SymPy symbols ``p, q`` (expanded)."""
        return _rho(self.gaps, P_SYM, Q_SYM, sympy.Integer(1), sympy.expand)

    def sign(self, p: Fraction, q: Fraction) -> int:
        """Sign of ``beta^N rho(P_F) - 1`` at ``(p, q)``, exactly."""
        rho = self.rho(p, q)
        if rho == 0:
            return -1
        if self.beta is None:
            v = self.beta_float**self.period * float(rho) - 1
            return (v > 0) - (v < 0)
        return int(self.beta.compare_power(self.period, 1 / rho))

    @property
    def exact(self) -> bool:
        return self.beta is not None and self.beta.is_rational

    def boundary_poly(self) -> Any:
        """``beta^N rho_F(p, q) - 1`` as a SymPy expression (rational ``beta``), else ``None``."""
        if not self.exact:
            return None
        b = self.beta.expr()
        return sympy.expand(b**self.period * self.rho_expr() - 1)

    def equation(self) -> str:
        """The boundary in closed form: ``beta^N * prod_m u_{a_m+1}(p, q) = 1``."""
        beta = self.beta.text() if self.beta is not None else repr(self.beta_float)
        if not self.gaps:
            return f"({beta})**{self.period} = 1"
        factors: dict[int, int] = {}
        for a in self.gaps:
            factors[a + 1] = factors.get(a + 1, 0) + 1
        parts = []
        for k, mult in sorted(factors.items()):
            u = sympy.factor(_u(k, P_SYM, Q_SYM, sympy.expand))
            parts.append(f"({u})" + (f"**{mult}" if mult > 1 else ""))
        return f"({beta})**{self.period} * " + " * ".join(parts) + " = 1"

    def describe(self) -> dict[str, Any]:
        return {
            "block": self.block,
            "eigenvalues": list(self.eigenvalues),
            "period": self.period,
            "blind_set": list(self.allowed),
            "equation": self.equation(),
        }


def _gaps(allowed: set[int], period: int) -> tuple[int, ...]:
    missed = sorted(n for n in range(period) if n not in allowed)
    if not missed:
        return ()
    return tuple(sorted((missed[(i + 1) % len(missed)] - m - 1) % period for i, m in enumerate(missed)))


def _block_patterns(index: int, block: FmoBlock, res: SigmaResult, budget: Budget) -> list[GePattern]:
    N = res.period
    base: dict[str, Any] = dict(
        block=index,
        eigenvalues=block.eigenvalue_texts,
        period=N,
        beta=block.modulus_sq,
        beta_float=block.modulus_sq_float,
    )
    if res.fully_blind:
        return [GePattern(allowed=tuple(range(N)), gaps=(), **base)]
    if not res.degenerate:
        return [GePattern(allowed=(), gaps=(0,) * N, **base)]
    assert block.phase is not None
    space = SlotSpace.from_block(block.phase)
    found = search(space, budget, Margins(space.tol))
    out: dict[tuple[int, ...], GePattern] = {}
    for mask in found.maximal:
        phases = {n for n, _ in space.slots(mask)}
        allowed = {n for n in range(N) if n % space.n_phases in phases}
        gaps = _gaps(allowed, N)
        # rho depends only on the multiset of gaps: one pattern per multiset
        out.setdefault(gaps, GePattern(allowed=tuple(sorted(allowed)), gaps=gaps, **base))
    return list(out.values())


@dataclass(frozen=True)
class GeStructure:
    """Every (block, maximal blind pattern) pair that can bind, for one Gilbert-Elliott packet."""

    patterns: tuple[GePattern, ...]

    @property
    def exact(self) -> bool:
        return all(pt.exact for pt in self.patterns)

    def label(self, p: Fraction, q: Fraction) -> tuple[str, GePattern | None]:
        """Exact verdict at ``(p, q)`` and the pattern with the largest rate sign."""
        best, where = -2, None
        for pt in self.patterns:
            s = pt.sign(p, q)
            if s > best:
                best, where = s, pt
        return (_SIGN[best] if where is not None else "stable"), where

    def max_rate_float(self, p: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``max_F beta^(1) rho_F^(1/N)`` (the rate) and the index of the maximising pattern."""
        if not self.patterns:
            shape = np.broadcast(p, q).shape
            return np.zeros(shape), np.zeros(shape, dtype=int)
        rates = np.stack(
            [pt.beta_float * np.maximum(pt.rho_float(p, q), 0.0) ** (1.0 / pt.period) for pt in self.patterns]
        )
        return rates.max(axis=0), rates.argmax(axis=0)


def ge_structure(items: Sequence[tuple[FmoBlock, SigmaResult | None]], budget: Budget | None = None) -> GeStructure:
    """The binding patterns of every block with ``|alpha| >= 1`` (all maximal blind sets, one per gap multiset).

    Parameters
    ----------
    items:
        ``(block, sigma result)`` per FMO block as :func:`kfio.analyze` has
        them (``None`` for blocks inside the unit circle).  The blind sets do
        not depend on the channel, so the enumeration is done once here.
    """
    budget = budget if budget is not None else Budget(max_steps=200_000)
    patterns: list[GePattern] = []
    for i, (block, res) in enumerate(items):
        if res is not None:
            patterns.extend(_block_patterns(i, block, res, budget))
    return GeStructure(tuple(patterns))


# --- critical values on a line -------------------------------------------------------------


@dataclass(frozen=True)
class Crossing(ReportPart):
    """A point where the exact label changes along a line."""

    value: float
    value_exact: str | None
    left: str
    right: str
    pattern: GePattern | None


@dataclass(frozen=True)
class LineResult(ReportPart):
    """The verdict along ``p = p0`` (variable ``q``) or ``q = q0`` (variable ``p``), exactly.

    Attributes
    ----------
    variable:
        ``"recovery_rate"`` (q varies) or ``"failure_rate"`` (p varies).
    fixed:
        The other rate, as exact text.
    intervals:
        ``(lower, upper, label)`` covering ``(0, 1)``, labels exact.
    crossings:
        The critical values: where the label changes.
    exact:
        Roots are exact algebraic numbers (``beta`` rational).
    """

    variable: str
    fixed: str
    intervals: tuple[tuple[float, float, str], ...]
    crossings: tuple[Crossing, ...]
    exact: bool

    @property
    def critical(self) -> Crossing | None:
        """The single critical value when there is exactly one crossing."""
        return self.crossings[0] if len(self.crossings) == 1 else None

    def status(self) -> str:
        if self.crossings:
            return "threshold" if len(self.crossings) == 1 else "several"
        return f"{self.intervals[0][2]} for every {self.variable.replace('_', ' ')}"


def _numeric_roots(structure: GeStructure, pt: GePattern, var: str, fixed: Fraction) -> list[mpmath.mpf]:
    """Sign changes of ``beta^N rho - 1`` on a fine grid, refined by bisection (irrational ``beta``)."""
    xs = np.linspace(1e-9, 1 - 1e-9, 4001)
    fx = np.full_like(xs, float(fixed))
    p, q = (fx, xs) if var == "q" else (xs, fx)
    g = pt.beta_float**pt.period * pt.rho_float(p, q) - 1
    out = []
    for i in np.flatnonzero(np.sign(g[:-1]) * np.sign(g[1:]) < 0):
        lo, hi = float(xs[i]), float(xs[i + 1])
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            pm, qm = (float(fixed), mid) if var == "q" else (mid, float(fixed))
            gm = pt.beta_float**pt.period * float(pt.rho_float(np.array(pm), np.array(qm))) - 1
            if np.sign(gm) == np.sign(g[i]):
                lo = mid
            else:
                hi = mid
        out.append(mpmath.mpf(0.5 * (lo + hi)))
    return out


def critical_on_line(structure: GeStructure, var: str, fixed: Fraction) -> LineResult:
    """Exact verdict along a line of the (p, q) square and its critical values.

    ``var = "q"``: ``p = fixed`` and ``q`` varies (the critical recovery rate
    ``q*(p)``); ``var = "p"``: ``q = fixed`` and ``p`` varies (``p*(q)``).
    Candidates are the real roots in ``(0, 1)`` of every pattern's boundary
    polynomial ``beta^N rho_F - 1`` (exact ``CRootOf``); the label of each
    interval between them is decided exactly at a rational midpoint, and a
    critical value is a candidate where the label changes.

    Examples
    --------
    ``A = (5/4) diag(1, -1)``, ``C = [1 1]`` at ``p = 1/4``:
    ``(25/16)^2 ((1 - q)^2 + q / 4) = 1``, smaller root.

    >>> from kfio import load_request, analyze
    >>> r = analyze(load_request('{"system": {"A": [["5/4", 0], [0, "-5/4"]], "C": [[1, 1]]}, '
    ...     '"channel": {"model": "gilbert_elliott", "failure_rate": "1/4", "recovery_rate": "1/2"}}'))
    >>> line = r.gilbert_elliott.recovery
    >>> line.critical.value_exact, round(line.critical.value, 6), line.critical.left
    ('7/8 - sqrt(7009)/200', 0.456401, 'unstable')
    """
    x = Q_SYM if var == "q" else P_SYM
    other = P_SYM if var == "q" else Q_SYM
    exact = structure.exact
    candidates: list[Candidate[GePattern]] = []
    for pt in structure.patterns:
        if exact:
            poly = pt.boundary_poly().subs(other, sympy.Rational(fixed.numerator, fixed.denominator))
            add_candidates(candidates, roots_in_unit(poly, x), pt)
        else:
            candidates.extend(Candidate(r, None, [pt]) for r in _numeric_roots(structure, pt, var, fixed))

    def label_at(v: Fraction) -> tuple[str, GePattern | None]:
        return structure.label(fixed, v) if var == "q" else structure.label(v, fixed)

    intervals, changes = scan(candidates, label_at)
    crossings = tuple(Crossing(c.value, c.exact_text, c.left, c.right, c.tag) for c in changes)
    name = "recovery_rate" if var == "q" else "failure_rate"
    return LineResult(name, _frac_text(fixed), intervals, crossings, exact)


def _frac_text(x: Fraction) -> str:
    return str(x.numerator) if x.denominator == 1 else f"{x.numerator}/{x.denominator}"


# --- the (p, q) map -------------------------------------------------------------------------


@dataclass(frozen=True)
class GeMap(ReportPart):
    """Exact labels on a ``K x K`` grid of cell centres and the boundary curve, piece by piece.

    Attributes
    ----------
    rates:
        Cell centres ``(i + 1/2) / K``, the same for ``p`` and ``q``.
    labels:
        ``labels[i][j]`` is the exact verdict at ``p = rates[i]``, ``q = rates[j]``.
    pieces:
        One entry per (block, pattern) that is binding somewhere on the curve,
        with its closed-form equation.
    curve:
        Points ``(q, p, piece)`` on the boundary (float), sampled along both axes.
    """

    rates: tuple[float, ...]
    labels: tuple[tuple[str, ...], ...]
    pieces: tuple[dict[str, Any], ...]
    curve: tuple[tuple[float, float, int], ...]
    exact: bool


def _curve_points(structure: GeStructure, samples: int) -> list[tuple[float, float, int]]:
    """Boundary points where ``max_F rate_F = 1``, along ``samples`` lines in each direction (float)."""
    fine = np.linspace(1e-6, 1 - 1e-6, 2001)
    lines = (np.arange(samples) + 0.5) / samples
    out = []
    for var in ("q", "p"):
        for c in lines:
            fixed = np.full_like(fine, c)
            p, q = (fixed, fine) if var == "q" else (fine, fixed)
            rate, _ = structure.max_rate_float(p, q)
            g = np.log(np.maximum(rate, 1e-300))
            for i in np.flatnonzero(np.sign(g[:-1]) * np.sign(g[1:]) < 0):
                lo, hi = fine[i], fine[i + 1]
                for _ in range(50):
                    mid = 0.5 * (lo + hi)
                    pm, qm = (c, mid) if var == "q" else (mid, c)
                    rm, _ = structure.max_rate_float(np.array(pm), np.array(qm))
                    if np.sign(np.log(float(rm))) == np.sign(g[i]):
                        lo = mid
                    else:
                        hi = mid
                x = 0.5 * (lo + hi)
                pm, qm = (c, x) if var == "q" else (x, c)
                _, arg = structure.max_rate_float(np.array(pm), np.array(qm))
                out.append((float(qm), float(pm), int(arg)))
    return out


def ge_map(structure: GeStructure, grid: int, samples: int | None = None) -> GeMap:
    """The (p, q) square on a ``grid x grid`` mesh, labelled exactly, and the boundary curve.

    Each cell centre is a rational point, so its label is Theorem 1's exact
    verdict (:meth:`GeStructure.label`).  The curve is drawn from float
    evaluations of the same closed forms (bisection to ``1e-15``); each piece
    is named by its exact equation.
    """
    rates = [Fraction(2 * i + 1, 2 * grid) for i in range(grid)]
    labels = tuple(tuple(structure.label(p, q)[0] for q in rates) for p in rates)
    points = _curve_points(structure, samples or grid)
    used = sorted({k for _, _, k in points})
    index = {k: i for i, k in enumerate(used)}
    pieces = []
    for k in used:
        pt = structure.patterns[k]
        d = pt.describe()
        d["points"] = sum(1 for *_, j in points if j == k)
        pieces.append(d)
    curve = tuple((q, p, index[k]) for q, p, k in points)
    return GeMap(tuple(float(r) for r in rates), labels, tuple(pieces), curve, structure.exact)


# --- the report -----------------------------------------------------------------------------


@dataclass(frozen=True)
class GeRegion(ReportPart):
    """What ``analyze`` reports for one Gilbert-Elliott packet.

    Attributes
    ----------
    recovery:
        The line ``p = p0`` of the request: the critical recovery rate ``q*(p0)``.
    failure:
        The line ``q = q0``: the critical failure rate ``p*(q0)``.
    patterns:
        Every binding (block, blind pattern) with its boundary equation.
    map:
        The (p, q) map when the request asks for one (``options.analyze.ge_grid``).
    """

    recovery: LineResult
    failure: LineResult
    patterns: tuple[GePattern, ...]
    map: GeMap | None = None
    basis: str = "theorem"

    def summary_lines(self) -> list[str]:
        out = []
        for line, name in ((self.recovery, "recovery rate q"), (self.failure, "failure rate p")):
            fixed = f"at {'p' if line.variable == 'recovery_rate' else 'q'} = {readable(line.fixed)}"
            if line.crossings:
                parts = ", ".join(f"{critical_text(c.value_exact, c.value)} [{c.left} below]" for c in line.crossings)
                out.append(f"critical {name} {fixed}: {parts}")
            else:
                out.append(f"critical {name} {fixed}: none ({line.status()})")
        return out


def ge_region(
    items: Sequence[tuple[FmoBlock, SigmaResult | None]],
    channel: MarkovChannel,
    budget: Budget | None = None,
    grid: int | None = None,
) -> GeRegion:
    """Critical rates at the request's ``p`` and ``q`` and, if ``grid`` is given, the (p, q) map.

    Parameters
    ----------
    items:
        ``(block, sigma result)`` per FMO block.
    channel:
        The Gilbert-Elliott channel of the request (``table = (q, 1 - p)``).
    grid:
        Cells per axis of the map, or ``None`` for no map.
    """
    structure = ge_structure(items, budget)
    q0, p0 = channel.table[0], 1 - channel.table[1]
    return GeRegion(
        recovery=critical_on_line(structure, "q", p0),
        failure=critical_on_line(structure, "p", q0),
        patterns=structure.patterns,
        map=ge_map(structure, grid) if grid else None,
    )


__all__ = [
    "Crossing",
    "GeMap",
    "GePattern",
    "GeRegion",
    "GeStructure",
    "LineResult",
    "critical_on_line",
    "ge_map",
    "ge_region",
    "ge_structure",
]
