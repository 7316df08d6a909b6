"""Rohr, Marelli and Fu (2014), Theorem 1: the exact stability verdict for any ``A`` and Markov channel.

The expected error covariance stays bounded iff ``|alpha_k|^2 sigma_k < 1``
for every FMO block ``k``, and diverges if some block has ``> 1``; ``= 1`` is
the theorem's gap, reported as ``boundary``.  Pipeline (docs/theory.md):
exact eigenstructure (:mod:`kfio.structure._eigen`), FMO blocks in phase form
(:mod:`kfio.structure._fmo`), ``sigma_k`` over maximal blind phase sets
(:mod:`kfio.sigma._sigma`), exact comparison with 1 (:mod:`kfio.sigma._decide`).
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Mapping, Optional, Sequence

import mpmath
import sympy
from flint import fmpq_mat

from .._budget import Budget
from .._json import json_float
from .._reporting import Report, ShortRepr
from .._reuse import Memo, kept
from .._verdicts import Verdict
from ..design import (
    CriticalParameter,
    GeRegion,
    TailReport,
    analyze_options,
    critical_parameter,
    ge_region,
    region_report,
    tail_kappa,
    tail_report,
)
from ..errors import BudgetExceeded
from ..model import MarkovChannel, PerSensorChannel, Request, packets_of, require_assumption_1
from ..model import SystemRecord as System
from ..sigma import (
    VERDICTS,
    SigmaBracket,
    SigmaBudgetExceeded,
    SigmaResult,
    bernoulli_factor,
    compare_rate_bernoulli,
    compare_rate_markov,
    compute_sigma,
    period_transfer_matrix,
)
from ..structure import (
    SHORT_TEXT_CHARS,
    START_PREC,
    AlgebraicReal,
    FmoBlock,
    fmo_blocks,
    precision,
    readable,
    short_text,
    to_fmpq_mat,
)
from ._radicals import RealRadical

#: Default wall-clock budget (s) of one analysis when the request sets none.
DEFAULT_BUDGET_S = 120.0


@dataclass(frozen=True, repr=False)
class BlockReport(ShortRepr):
    """Theorem 1 applied to one FMO block.

    ``certified`` is true when every decision the block's verdict rests on
    was proved (its eigenvalue classes, the rank decisions ``sigma`` rests
    on, the comparison with 1), not when every rank decision of the blind-set
    search was: the search's completeness rests on its numerical ranks.  The
    one precise definition is in docs/theory.md, "What certified means".
    """

    _repr_fields = ("eigenvalues", "modulus", "period", "sigma", "rate", "verdict")

    eigenvalues: tuple[str, ...]
    eigenvalues_numeric: tuple[complex, ...]
    modulus: float
    modulus_exact: str | None
    jordan_sizes: tuple[int, ...]
    period: int | None
    degenerate: bool | None
    sigma: float | None
    sigma_exact: str | None
    rate: float | None
    verdict: Verdict
    certified: bool
    blind_set: list[list[int]] | None = None
    basis: str = "theorem"
    notes: tuple[str, ...] = ()
    bernoulli_blind_fraction: tuple[Fraction, ...] | None = field(default=None, repr=False)
    modulus_sq_algebraic: AlgebraicReal | None = field(default=None, repr=False)

    @property
    def modulus_sq_expr(self) -> Any:
        """``|alpha|^2`` as a SymPy expression (``Rational`` or ``CRootOf``), ``None`` when not exact."""
        return None if self.modulus_sq_algebraic is None else self.modulus_sq_algebraic.expr()

    def __post_init__(self) -> None:
        object.__setattr__(self, "verdict", Verdict(self.verdict))

    def _repr_items(self) -> list[tuple[str, Any]]:
        # long algebraic texts (CRootOf with 100-digit coefficients) stay in to_dict(); the repr shows their value
        shown = tuple(readable(t, z) for t, z in zip(self.eigenvalues, self.eigenvalues_numeric))
        return [("eigenvalues", shown), *super()._repr_items()[1:]]


@dataclass(frozen=True, repr=False)
class StabilityReport(Report):
    """The verdict of Theorem 1 for a whole request, with its evidence.

    Every attribute has the name of its key in :meth:`to_dict` (the JSON of
    ``kfio analyze --json``) but one: the Gilbert-Elliott region is the
    attribute ``gilbert_elliott`` and the JSON key ``gilbert_elliott_region``;
    :attr:`gilbert_elliott_region` is the same object under the JSON's name.
    """

    _repr_fields = ("verdict", "critical_arrival_probability", "critical_arrival_probability_exact", "blocks")

    verdict: Verdict
    blocks: tuple[BlockReport, ...]
    critical_arrival_probability: float | None
    critical_arrival_probability_exact: str | None
    channel: dict[str, Any]
    system: dict[str, Any]
    assumptions: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()
    regions: Optional[dict[str, Any]] = None
    tail: Optional[TailReport] = None
    gilbert_elliott: Optional[GeRegion] = None
    critical_parameter: Optional[CriticalParameter] = None

    #: Short forms of long exact texts for :meth:`summary` (never in the JSON).
    display: Mapping[str, str] = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "verdict", Verdict(self.verdict))

    @property
    def gilbert_elliott_region(self) -> Optional[GeRegion]:
        """:attr:`gilbert_elliott` under its JSON key's name (``to_dict()["gilbert_elliott_region"]``)."""
        return self.gilbert_elliott

    def _short(self, text: str, value: complex | float | None) -> str:
        return self.display.get(text) or readable(text, value)

    def _number(self, text: str, value: float | None) -> str:
        """kfio's one number format (:func:`kfio._numbers.summary_number`), with this report's short forms."""
        from .._numbers import summary_number

        return summary_number(text, value, readable=self._short(text, value))

    def _repr_items(self) -> list[tuple[str, Any]]:
        items = dict(super()._repr_items())
        exact = self.critical_arrival_probability_exact
        if exact is not None:
            items["critical_arrival_probability_exact"] = self._short(exact, self.critical_arrival_probability)
        return list(items.items())

    def summary(self) -> str:
        """Readable multi-line summary for the terminal."""
        lines = [f"verdict: {self.verdict.upper()}  (Rohr, Marelli and Fu 2014, Theorem 1)"]
        if self.critical_arrival_probability_exact is not None:
            crit = self._number(self.critical_arrival_probability_exact, self.critical_arrival_probability)
            lines.append(f"critical arrival probability: {crit}")
        lines.append("finite multiplicative order (FMO) blocks, largest modulus first:")
        for b in self.blocks:
            eig = ", ".join(self._short(t, z) for t, z in zip(b.eigenvalues, b.eigenvalues_numeric))
            modulus = _shown(b.modulus, b.modulus_exact)
            if b.rate is None:
                lines.append(f"  [{b.verdict}] eigenvalues {eig}: |alpha| = {modulus} < 1, stable for any channel")
                continue
            deg = "degenerate" if b.degenerate else "non-degenerate"
            lines.append(
                f"  [{b.verdict}] eigenvalues {eig}: |alpha| = {modulus}, {deg}, period {b.period}, "
                f"sigma = {_shown(b.sigma, b.sigma_exact)}, rate |alpha|^2 sigma = {_shown(b.rate, None)}"
                + ("" if b.certified else "  (not certified)")
            )
        for s in (self.regions or {}).get("sensors", []):
            if s.get("status") == "threshold":
                crit = self._number(s["critical_arrival_probability_exact"], s["critical_arrival_probability"])
            else:
                crit = {"zero": "0 (any arrival probability)", "none": "none: no arrival probability suffices"}.get(
                    s.get("status"), str(s.get("status"))
                )
            lines.append(f"sensor {s['sensor']}: critical arrival probability given the others {crit}  [extension]")
        if self.tail is not None:
            lines.extend(self.tail.summary_lines())
        if self.gilbert_elliott is not None:
            lines.extend(self.gilbert_elliott.summary_lines())
        if self.critical_parameter is not None:
            lines.extend(self.critical_parameter.summary_lines())
        for a in self.assumptions:
            lines.append(f"assumption: {a}")
        for w in self.warnings:
            lines.append(f"warning: {w}")
        return "\n".join(lines)


def _shown(x: float | None, exact: str | None) -> str:
    """A float for the terminal, or its exact text when it is outside float64's range."""
    if json_float(x) is not None:
        return f"{x:.6g}"
    return exact if exact is not None else "beyond floating-point range"


def _channels_of(request: Request) -> list[MarkovChannel]:
    return [p.channel for p in packets_of(request)]


def _controllable(system: System) -> bool | None:
    """Whether ``(A, Q^{1/2})`` is controllable: ``rank [Q, AQ, ..., A^{n-1} Q] = n`` over ``Q``.

    Exact, in FLINT's ``fmpq_mat`` (the Krylov columns are added one ``A Q``
    product at a time, and the rank stops growing once it stops growing).
    """
    if system.Q is None:
        return None
    A, M = to_fmpq_mat(system.A), to_fmpq_mat(system.Q)
    n, K, rank = system.n, M, M.rank()
    for _ in range(n - 1):
        if rank == n:
            break
        M = A * M
        rows_K, rows_M = K.table(), M.table()
        K2 = fmpq_mat(n, K.ncols() + n, [x for i in range(n) for x in (*rows_K[i], *rows_M[i])])
        new_rank = K2.rank()
        if new_rank == rank:  # the Krylov space stopped growing: it never grows again
            break
        K, rank = K2, new_rank
    return rank == n


def _modulus_text(block: FmoBlock) -> str | None:
    """SymPy's text of ``sqrt(|alpha|^2)``: ``sqrt(CRootOf(...))`` is written directly (see :mod:`kfio.structure._texts`)."""
    if block.modulus_sq is None or not block.modulus_sq.writable():
        return None
    root = block.modulus_sq.root_text()
    return f"sqrt({root})" if root is not None else str(sympy.sqrt(block.modulus_sq.expr()))


def _modulus_float(block: FmoBlock) -> float:
    """``|alpha|`` from the exact ``|alpha|^2`` when there is one (``10^160`` is a float, its square is not)."""
    if block.modulus_sq is None:
        return block.modulus
    with mpmath.workdps(30):
        return float(mpmath.sqrt(block.modulus_sq.approx(20)))


@functools.lru_cache(maxsize=4096)
def _radical_float(r: RealRadical) -> float:
    """``sigma`` as a float: the exact radical's 20-digit value, rounded.

    A function of the exact value alone (the key is ``r``'s base and index), so
    the points of a sweep that share ``sigma = (1 - lambda)^(z/N)`` (the same
    probabilities on many plants) compute it once; the float is the same.
    """
    return float(r.approx(20))


def _sigma_exact(res: SigmaResult, c: Fraction | None) -> RealRadical | None:
    """``sigma = c^(1/N)`` with ``c = sigma^N`` the exact rational of Corollary 2 (Bernoulli channels)."""
    if res.fully_blind:
        return RealRadical.of(Fraction(1), 1)
    if c is None or c == 0:
        return None
    return RealRadical.of(c, res.period)


def sigma_bracket_json(block: FmoBlock, bracket: SigmaBracket) -> dict[str, Any]:
    """The bracket on ``sigma_k`` a cut-short search proved, and what it decides (Theorem 1).

    ``sigma`` lies between the two ends (:class:`kfio.sigma.SigmaBracket` says
    what proves each); ``|alpha|^2 sigma_lower > 1`` already proves that the
    expected covariance diverges, ``|alpha|^2 sigma_upper < 1`` that this
    block does not make it diverge (Rohr, Marelli and Fu (2014), Theorem 1).
    The comparisons are exact (``sigma^N0`` is rational) when ``|alpha|^2``
    has an exact form, else from its certified enclosure.
    """
    N0 = bracket.phases
    ends: dict[str, Any] = {}
    signs = []
    for name, c in (("lower", bracket.lower), ("upper", bracket.upper)):
        root = RealRadical.of(c, N0)
        sign, exact = compare_rate_bernoulli(block.modulus_sq, block.modulus_sq_float, N0, c, block.compare_power)
        signs.append((sign, exact))
        ends[name] = {"sigma": float(root.approx(20)), "sigma_exact": root.text()}
    ends["lower"]["blind_set"] = [list(slot) for slot in bracket.lower_set]
    ends["lower"]["miss_counts"] = list(bracket.lower_misses)
    ends["lower"]["proof"] = (
        "the empty set, blind in every block"
        if not bracket.lower_set
        else "a maximal blind set the search found, its rank drop "
        + ("confirmed in exact arithmetic" if bracket.lower_exact else "decided numerically (no exact oracle)")
    )
    ends["upper"]["miss_counts_at_least"] = None if bracket.upper_misses is None else list(bracket.upper_misses)
    ends["upper"]["proof"] = (
        "sigma <= 1 (the search for each sensor alone did not finish)"
        if bracket.upper_misses is None
        else "each sensor alone: its largest blind set (one-sensor branch and bound) bounds the phases every blind "
        "set misses"
    )
    (lo, lo_exact), (hi, hi_exact) = signs
    if lo > 0:
        implies = "unstable: |alpha|^2 sigma > 1 already at the lower end, so the expected covariance diverges"
    elif hi < 0:
        implies = "this block is stable: |alpha|^2 sigma < 1 at the upper end (other blocks were not all decided)"
    else:
        implies = "undecided: |alpha|^2 sigma - 1 changes sign inside the bracket"
    return {
        "block_eigenvalues": list(block.eigenvalue_texts),
        "modulus": _modulus_float(block),
        "phases": N0,
        "sigma_lower": ends["lower"],
        "sigma_upper": ends["upper"],
        "found_miss_counts": [list(z) for z in bracket.found],
        "implies": implies,
        "exact_comparison": bool((lo_exact if lo > 0 else True) and (hi_exact if hi < 0 else True)),
    }


def _analyze_block(
    block: FmoBlock, channels: list[MarkovChannel], basis: str, budget: Budget, memo: Memo | None = None
) -> tuple[BlockReport, Optional[SigmaResult]]:
    modulus = kept(memo, "modulus", lambda: (_modulus_float(block), _modulus_text(block)))  # the block alone
    base: dict[str, Any] = dict(
        eigenvalues=block.eigenvalue_texts,
        eigenvalues_numeric=block.eigenvalue_values,
        modulus=modulus[0],
        modulus_exact=modulus[1],
        jordan_sizes=block.jordan_sizes,
        basis=basis,
        modulus_sq_algebraic=block.modulus_sq,
    )
    below_one, below_certified = kept(  # |alpha| < 1: the block alone
        memo, "below_one", lambda: (-1, True) if block.phase is None else block.compare_power(1, Fraction(1))
    )
    if below_one < 0:
        degenerate = None
        if block.phase is not None:
            degenerate = (
                block.phase.numeric_rank([(0, g) for g in range(len(block.phase.row_groups))]) < block.phase.n_columns
            )
        # certified iff |alpha| < 1 was proved (exactly or from a certified enclosure)
        return BlockReport(
            period=None,
            degenerate=degenerate,
            sigma=None,
            sigma_exact=None,
            rate=None,
            verdict=Verdict.STABLE,
            certified=below_certified,
            notes=block.notes + (() if below_certified else ("|alpha| < 1 was decided numerically, not proved",)),
            **base,
        ), None
    assert block.phase is not None  # the zero class has |alpha| = 0 < 1
    try:
        res = compute_sigma(block.phase, channels, budget, memo=None if memo is None else memo.setdefault("sigma", {}))
    except SigmaBudgetExceeded as exc:
        exc.partial = {"sigma_bracket": sigma_bracket_json(block, exc.bracket)}
        raise
    N = res.period
    lambdas = [ch.bernoulli_lambda for ch in channels]
    all_bernoulli = all(lam is not None and ch.model == "bernoulli" for lam, ch in zip(lambdas, channels))
    notes = list(block.notes) + list(res.notes)
    c: Fraction | None = None
    if res.fully_blind:
        s, exact = block.compare_power(1, Fraction(1))
        notes.append("no arrival pattern observes this block (sigma = 1): an unobservable mode")
    elif all_bernoulli and res.bernoulli_exponents is not None:
        lam_f = [lam for lam in lambdas if lam is not None]
        sets = res.maximal_blind_sets or (res.worst_blind_set,)
        shares = kept(  # the sets' shares z_g / N: no probability in them
            memo,
            ("exponents", N, len(channels), sets),
            lambda: [_bernoulli_exponents(F, N, len(channels)) for F in sets],
        )
        c = max(bernoulli_factor(z, lam_f, N) for z in shares)
        s, exact = compare_rate_bernoulli(block.modulus_sq, block.modulus_sq_float, N, c, block.compare_power)
    else:
        sets = res.maximal_blind_sets or (res.worst_blind_set,)
        signs = []
        exact = True
        for F in sets:
            budget.tick("exact transfer matrices")
            si, ex = compare_rate_markov(
                block.modulus_sq,
                block.modulus_sq_float,
                N,
                period_transfer_matrix(N, F, channels, budget),
                block.modulus_sq_ball,
            )
            signs.append(si)
            exact = exact and ex
        s = max(signs)
    certified = exact and res.certified and block.certified
    sigma_exact = _sigma_exact(res, c) if all_bernoulli else None
    sigma = _radical_float(sigma_exact) if sigma_exact is not None else res.sigma
    verdict = Verdict.of_sign(s)
    if not exact:
        notes.append("rate compared with 1 numerically (50 digits), not exactly")
    report = BlockReport(
        period=N,
        degenerate=res.degenerate,
        sigma=sigma,
        sigma_exact=sigma_exact.text() if sigma_exact is not None else None,
        rate=block.modulus_sq_float * sigma,
        verdict=verdict,
        certified=certified,
        blind_set=sorted([list(s) for s in res.worst_blind_set]),
        notes=tuple(notes),
        bernoulli_blind_fraction=res.bernoulli_exponents if all_bernoulli else None,
        **base,
    )
    return report, res


def _bernoulli_exponents(F: frozenset[tuple[int, int]], N: int, groups: int) -> tuple[Fraction, ...]:
    """``z_g / N``: the share of phases at which group ``g`` is *not* in the blind set ``F``."""
    return tuple(Fraction(N - sum(1 for n, g in F if g == grp), N) for grp in range(groups))


def _critical_probability(
    blocks: Sequence[BlockReport], display: dict[str, str]
) -> tuple[float | None, str | None, list[str]]:
    """Rohr, Marelli and Fu (2014), Corollary 2 + Theorem 1: ``lambda_c = max_k 1 - beta_k^(-N_k / z_k)``.

    Exact arithmetic only: for a rational ``beta_k`` the term is ``1 - r`` with
    ``r = beta_k^(-N_k/z_k)`` a :class:`RealRadical` (a rational when it is one,
    e.g. ``1 - 1/alpha^2`` for a rational real ``alpha``), compared exactly
    between blocks; for an algebraic ``beta_k`` it is ``1 - CRootOf(h, i)**(-N/z)``,
    valued from FLINT's certified enclosure of ``beta_k`` and rounded to a float
    (the float of the exact value), its text written as SymPy prints
    it; the float path (``beta_k`` not exact) stays in SymPy.  Long exact texts
    get a short form for the terminal in ``display`` (the JSON keeps the text).
    """
    warnings: list[str] = []
    candidates: list[tuple[mpmath.mpf, RealRadical | None, Any]] = []
    for b in blocks:
        if b.rate is None:
            continue
        assert b.bernoulli_blind_fraction is not None and b.period is not None
        share = b.bernoulli_blind_fraction[0]  # z / N
        if share == 0:
            warnings.append(
                f"block {', '.join(b.eigenvalues)} is never observed (sigma = 1) and |alpha| >= 1: "
                "no arrival probability makes the filter stable"
            )
            return None, None, warnings
        beta = b.modulus_sq_algebraic
        if beta is not None and beta.rational is not None:
            r = RealRadical.power(1 / beta.rational, 1 / share)
            with mpmath.workdps(50):
                candidates.append((1 - r.approx(40), r, None))
            continue
        if beta is not None:  # 1 - beta^(-1/share) from FLINT's certified enclosure of beta
            exponent = -1 / share
            with precision(START_PREC):
                value = float((1 - beta.power_ball(exponent)).mid())
            candidates.append((mpmath.mpf(value), None, (beta, exponent)))
            continue
        expr = 1 - sympy.Float(b.modulus**2, 30) ** (-1 / sympy.Rational(share.numerator, share.denominator))
        candidates.append((mpmath.mpf(str(sympy.N(expr, 40))), None, expr))
    if not candidates:
        return 0.0, "0", warnings
    radicals = [r for _, r, _ in candidates if r is not None]
    if len(radicals) == len(candidates):  # all exact: the largest 1 - r has the smallest r
        smallest = radicals[0]
        for r in radicals[1:]:
            if r.compare(smallest) < 0:
                smallest = r
        if smallest.compare(RealRadical.of(Fraction(1), 1)) >= 0:
            return 0.0, "0", warnings
        with mpmath.workdps(50):
            value = 1 - smallest.approx(40)
        return float(value), smallest.one_minus_text(), warnings
    val, rad, expr = max(candidates, key=lambda t: t[0])
    if val <= 0:
        return 0.0, "0", warnings
    degree: int | None = None
    if rad is not None:
        text = rad.one_minus_text()
    elif isinstance(expr, tuple):
        beta, exponent = expr
        text = _one_minus_power_text(beta, exponent)
        degree = beta.power_degree(exponent) if len(text) > SHORT_TEXT_CHARS else None
    else:
        text = str(expr)
    if len(text) > SHORT_TEXT_CHARS:
        display[text] = short_text(text, float(val), degree)
    return float(val), text, warnings


def _reused_critical_probability(
    blocks: Sequence[BlockReport], display: dict[str, str], memo: Memo | None
) -> tuple[float | None, str | None, list[str]]:
    """:func:`_critical_probability`, kept in the plant's ``memo`` by what it reads besides the plant.

    It reads each block's eigenvalues and ``beta_k`` (the plant), whether the
    block has a rate (``|alpha_k| >= 1``: the plant) and its share ``z_k / N_k``
    of observed phases (the worst blind set: for one Bernoulli packet the
    largest one, whatever ``lambda``), so those shares are the key.
    """
    if memo is None:
        return _critical_probability(blocks, display)
    key = ("critical", tuple((b.rate is None, b.bernoulli_blind_fraction) for b in blocks))
    if key not in memo:
        shown: dict[str, str] = {}
        crit, crit_exact, warnings = _critical_probability(blocks, shown)
        memo[key] = (crit, crit_exact, tuple(warnings), shown)
    crit, crit_exact, warnings, shown = memo[key]
    display.update(shown)
    return crit, crit_exact, list(warnings)


def _one_minus_power_text(beta: AlgebraicReal, exponent: Fraction) -> str:
    """SymPy's text of ``1 - beta**exponent`` (``exponent < 0``): ``1 - 1/CRootOf(...)**(3/2)``.

    Written from :meth:`AlgebraicReal.root_text` when SymPy prints the root as
    a plain ``CRootOf`` (``tests/structure/test_texts.py`` checks the form
    against SymPy's), else printed by SymPy.
    """
    root = beta.root_text()
    if root is None:
        return str(1 - beta.expr() ** sympy.Rational(exponent.numerator, exponent.denominator))
    e = -exponent
    power = "" if e == 1 else f"**{e}" if e.denominator == 1 else f"**({e})"
    return f"1 - 1/{root}{power}"


#: The Gilbert-Elliott region is computed unasked only for periods up to this (the boundary polynomials have
#: degree up to N, and every maximal blind set is enumerated: 51 059 orbits and minutes at N = 60).
GE_AUTO_MAX_PERIOD = 24
#: Closure-search steps the unasked Gilbert-Elliott region may use.
GE_AUTO_MAX_STEPS = 20_000


def _with_ge_region(
    report: StabilityReport,
    items: list[tuple[FmoBlock, SigmaResult | None]],
    channel: MarkovChannel,
    budget: Budget,
    opts: Any,
) -> StabilityReport:
    """Add the Gilbert-Elliott region; unasked (no ``ge_grid``), it never costs more than a small budget."""
    if opts.ge_grid is not None:
        return dataclasses.replace(report, gilbert_elliott=ge_region(items, channel, budget, opts.ge_grid))
    periods = [res.period for _, res in items if res is not None]
    skip = None
    if periods and max(periods) > GE_AUTO_MAX_PERIOD:
        skip = f"period {max(periods)} > {GE_AUTO_MAX_PERIOD}"
    else:
        try:
            region = ge_region(items, channel, Budget(max_steps=GE_AUTO_MAX_STEPS, seconds=budget.remaining()))
            return dataclasses.replace(report, gilbert_elliott=region)
        except BudgetExceeded:
            skip = f"more than {GE_AUTO_MAX_STEPS} closure-search steps"
    note = f"Gilbert-Elliott critical rates not computed ({skip}); ask with options.analyze.ge_grid"
    return dataclasses.replace(report, warnings=report.warnings + (note,))


def analyze(
    request: Request,
    budget: Budget | None = None,
    *,
    fmo: Sequence[FmoBlock] | None = None,
    memo: Memo | None = None,
    tail: str = "report",
) -> StabilityReport:
    """Decide stability of the expected error covariance (Rohr, Marelli and Fu (2014), Theorem 1).

    Parameters
    ----------
    request:
        A validated request (:func:`analyzer.load_request`).  ``Q`` and ``R``
        are not needed: the verdict does not depend on them.
    budget:
        Work budget; defaults to ``request.time_budget_s`` or 120 s.
    fmo:
        The FMO blocks of ``request.system`` (:func:`kfio.structure.fmo_blocks`),
        when the caller already has them (a sweep that varies only the
        channel); they depend on ``A`` and ``C`` alone.  Computed when omitted.
    memo:
        With ``fmo``: a dict the caller keeps for these blocks (and no other
        plant) across requests that differ in the channel.  What depends on
        the blocks alone is kept in it: ``|alpha_k|``, the blind-set searches
        whose sets do not depend on the probabilities
        (:func:`kfio.sigma.compute_sigma`'s ``memo``) and, for one Bernoulli
        packet, the critical probability (Rohr, Marelli and Fu (2014),
        Corollary 2: ``1 - beta_k^(-N_k / z_k)`` involves the plant and the
        blind set only).  The report equals the one without ``memo``.
    tail:
        ``"report"`` (the default): the whole :class:`kfio.design.TailReport`
        (Mo and Sinopoli, 2012).  ``"kappa"``: only its exponent ``kappa``
        (:meth:`TailReport.kappa_only`, the same float), for a sweep row that
        prints nothing else of the tail; the exact moment comparisons and
        texts are skipped.

    Returns
    -------
    StabilityReport
        ``verdict`` is ``stable`` if ``|alpha_k|^2 sigma_k < 1`` for every FMO
        block, ``unstable`` if ``> 1`` for some block, else ``boundary``.

    Raises
    ------
    AssumptionViolation
        A channel probability of 0 or 1 (Rohr, Marelli and Fu (2014), Assumption 1).
    BudgetExceeded
        The blind-set search did not finish within the budget.

    Examples
    --------
    >>> from kfio import load_request
    >>> req = load_request('{"system": {"A": [[1.1]], "C": [[1]]}, '
    ...                    '"channel": {"model": "bernoulli", "arrival_probability": "21/121"}}')
    >>> analyze(req).verdict
    'boundary'
    """
    opts = analyze_options(request)
    require_assumption_1(request.channel)
    if budget is None:
        budget = Budget(seconds=request.time_budget_s or DEFAULT_BUDGET_S)
    system = request.system
    channels = _channels_of(request)
    basis = "extension" if len(channels) > 1 else "theorem"
    if fmo is None:
        fmo, memo = fmo_blocks(system, budget), None
    blocks_memo = None if memo is None else memo.setdefault("blocks", [{} for _ in fmo])
    analyzed = [
        _analyze_block(b, channels, basis, budget, None if blocks_memo is None else blocks_memo[i])
        for i, b in enumerate(fmo)
    ]
    blocks = [rep for rep, _ in analyzed]

    def items_of() -> list[tuple[FmoBlock, Any]]:
        return [(b, res) for b, (_, res) in zip(fmo, analyzed)]

    verdict = max((b.verdict for b in blocks), key=VERDICTS.index, default=Verdict.STABLE)
    warnings: list[str] = []
    assumptions: list[str] = []
    if basis == "extension":
        assumptions.append(
            "per-sensor channels: the construction of Rohr, Marelli and Fu 2014 applied to separately lost packets "
            "(docs/theory.md, 'Per-sensor exact regions'); a kfio extension, not a theorem of the papers"
        )
    crit = crit_exact = None
    display: dict[str, str] = {}
    if len(channels) == 1 and channels[0].model == "bernoulli":
        crit, crit_exact, w = _reused_critical_probability(blocks, display, memo)
        warnings.extend(w)
    # the memo is the plant's (exact A): with exact Q the key is complete
    controllable = kept(memo, ("controllable", system.Q), lambda: _controllable(system))
    if controllable is False:
        warnings.append("(A, Q^1/2) is not controllable: some modes receive no process noise")
    ch = request.channel
    channel_desc = (
        {"model": "per_sensor", "channels": {name: c.describe() for name, c in ch.channels}}
        if isinstance(ch, PerSensorChannel)
        else ch.describe()
    )
    report = StabilityReport(
        verdict=verdict,
        blocks=tuple(blocks),
        critical_arrival_probability=crit,
        critical_arrival_probability_exact=crit_exact,
        channel=channel_desc,
        system={"n": system.n, "p": system.p, "controllable_A_Q": controllable},
        assumptions=tuple(assumptions),
        warnings=tuple(warnings),
        display=display,
        tail=(
            TailReport.kappa_only(tail_kappa(items_of(), channels, blocks_memo))
            if tail == "kappa"
            else tail_report(items_of(), channels, blocks_memo)
        ),
    )
    if len(channels) == 1 and channels[0].model == "gilbert_elliott":
        report = _with_ge_region(report, items_of(), channels[0], budget, opts)
    if opts.critical_parameter is not None:
        items = [(b, res) for b, (_, res) in zip(fmo, analyzed)]
        found = critical_parameter(request, opts.critical_parameter, items, channels, budget)
        report = dataclasses.replace(report, critical_parameter=found)
    if basis != "extension":
        return report
    # per-sensor Bernoulli channels: exact critical probability of each sensor, and for two
    # sensors the boundary curve (an extension of Rohr, Marelli and Fu (2014), see docs/regions.md)
    regions = region_report(request, budget, report=report, fmo=fmo, sigma=[res for _, res in analyzed])
    return dataclasses.replace(report, regions=regions)


__all__ = ["BlockReport", "StabilityReport", "analyze"]
