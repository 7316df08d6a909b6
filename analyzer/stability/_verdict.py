"""Seed 001, Theorem 1: the exact stability verdict for any ``A`` and Markov channel.

The expected error covariance stays bounded iff ``|alpha_k|^2 sigma_k < 1``
for every FMO block ``k``, and diverges if some block has ``> 1``; ``= 1`` is
the theorem's gap, reported as ``boundary``.  Pipeline (MATH.md section 2):
exact eigenstructure (:mod:`kfio.structure._eigen`), FMO blocks in phase form
(:mod:`kfio.structure._fmo`), ``sigma_k`` over maximal blind phase sets
(:mod:`kfio.stability._sigma`), exact comparison with 1 (:mod:`kfio.stability._decide`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Optional, Sequence

import mpmath
import sympy

from .._budget import Budget
from ..errors import InvalidInput
from ..model._request import require_assumption_1
from ..model._types import MarkovChannel, PerSensorChannel, Request, System, to_domain
from ..structure._fmo import FmoBlock, fmo_blocks
from ._decide import bernoulli_factor, compare_rate_bernoulli, compare_rate_markov
from ._regions import region_report
from ._sigma import SigmaResult, compute_sigma, period_transfer_matrix

VERDICTS = ("stable", "boundary", "unstable")
#: Default wall-clock budget (s) of one analysis when the request sets none.
DEFAULT_BUDGET_S = 120.0


@dataclass(frozen=True)
class BlockReport:
    """Theorem 1 applied to one FMO block."""

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
    verdict: str
    certified: bool
    blind_set: list[list[int]] | None = None
    basis: str = "theorem"
    notes: tuple[str, ...] = ()
    bernoulli_blind_fraction: tuple[Fraction, ...] | None = field(default=None, repr=False)
    modulus_sq_expr: Any = field(default=None, repr=False)

    def to_dict(self) -> dict[str, Any]:
        return {
            "eigenvalues": list(self.eigenvalues),
            "eigenvalues_numeric": [[z.real, z.imag] for z in self.eigenvalues_numeric],
            "modulus": self.modulus,
            "modulus_exact": self.modulus_exact,
            "jordan_sizes": list(self.jordan_sizes),
            "period": self.period,
            "degenerate": self.degenerate,
            "sigma": self.sigma,
            "sigma_exact": self.sigma_exact,
            "rate": self.rate,
            "verdict": self.verdict,
            "certified": self.certified,
            "blind_set": self.blind_set,
            "basis": self.basis,
            "notes": list(self.notes),
        }


@dataclass(frozen=True)
class StabilityReport:
    """The verdict of Theorem 1 for a whole request, with its evidence."""

    verdict: str
    blocks: tuple[BlockReport, ...]
    critical_arrival_probability: float | None
    critical_arrival_probability_exact: str | None
    channel: dict[str, Any]
    system: dict[str, Any]
    assumptions: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()
    regions: Optional[dict[str, Any]] = None

    def to_dict(self) -> dict[str, Any]:
        """The JSON report (stable field names; see README)."""
        return {
            "verdict": self.verdict,
            "theorem": "seed 001 (Rohr, Marelli, Fu), Theorem 1",
            "blocks": [b.to_dict() for b in self.blocks],
            "critical_arrival_probability": self.critical_arrival_probability,
            "critical_arrival_probability_exact": self.critical_arrival_probability_exact,
            "channel": self.channel,
            "system": self.system,
            "assumptions": list(self.assumptions),
            "warnings": list(self.warnings),
            "regions": self.regions,
        }

    def summary(self) -> str:
        """Readable multi-line summary for the terminal."""
        lines = [f"verdict: {self.verdict.upper()}  (seed 001, Theorem 1)"]
        if self.critical_arrival_probability_exact is not None:
            lines.append(
                f"critical arrival probability: {self.critical_arrival_probability:.6g}"
                f"  (exact: {self.critical_arrival_probability_exact})"
            )
        lines.append("FMO blocks (largest modulus first):")
        for b in self.blocks:
            eig = ", ".join(b.eigenvalues)
            if b.rate is None:
                lines.append(
                    f"  [{b.verdict}] eigenvalues {eig}: |alpha| = {b.modulus:.6g} < 1, stable for any channel"
                )
                continue
            deg = "degenerate" if b.degenerate else "non-degenerate"
            lines.append(
                f"  [{b.verdict}] eigenvalues {eig}: |alpha| = {b.modulus:.6g}, {deg}, period {b.period}, "
                f"sigma = {b.sigma:.6g}, rate |alpha|^2 sigma = {b.rate:.6g}"
                + ("" if b.certified else "  (not certified)")
            )
        for s in (self.regions or {}).get("sensors", []):
            if s.get("status") == "threshold":
                crit = f"{s['critical_arrival_probability']:.6g} (exact: {s['critical_arrival_probability_exact']})"
            else:
                crit = {"zero": "0 (any arrival probability)", "none": "none: no arrival probability suffices"}.get(
                    s.get("status"), str(s.get("status"))
                )
            lines.append(f"sensor {s['sensor']}: critical arrival probability given the others {crit}  [extension]")
        for a in self.assumptions:
            lines.append(f"assumption: {a}")
        for w in self.warnings:
            lines.append(f"warning: {w}")
        return "\n".join(lines)


def _channels_of(request: Request) -> list[MarkovChannel]:
    ch = request.channel
    if isinstance(ch, PerSensorChannel):
        return [ch.for_sensor(s.name) for s in (request.system.sensors or ())]
    return [ch]


def _controllable(system: System) -> bool | None:
    """Whether ``(A, Q^{1/2})`` is controllable: ``rank [Q, AQ, ..., A^{n-1} Q] = n`` over ``Q``."""
    if system.Q is None:
        return None
    A, Q = to_domain(system.A), to_domain(system.Q)
    blocks, M = [Q], Q
    for _ in range(system.n - 1):
        M = A * M
        blocks.append(M)
    K = blocks[0].hstack(*blocks[1:]) if len(blocks) > 1 else blocks[0]
    return bool(K.rank() == system.n)


def _modulus_text(block: FmoBlock) -> str | None:
    if block.modulus_sq is None:
        return None
    return str(sympy.sqrt(block.modulus_sq.expr()))


def _sigma_exact_text(res: SigmaResult, lambdas: Sequence[Fraction]) -> str | None:
    if res.bernoulli_exponents is None:
        return None
    expr = sympy.Integer(1)
    for e, lam in zip(res.bernoulli_exponents, lambdas):
        base = 1 - sympy.Rational(lam.numerator, lam.denominator)
        expr *= base ** sympy.Rational(e.numerator, e.denominator)
    return str(sympy.nsimplify(expr))


def _analyze_block(
    block: FmoBlock, channels: list[MarkovChannel], basis: str, budget: Budget
) -> tuple[BlockReport, Optional[SigmaResult]]:
    base: dict[str, Any] = dict(
        eigenvalues=block.eigenvalue_texts,
        eigenvalues_numeric=block.eigenvalue_values,
        modulus=block.modulus,
        modulus_exact=_modulus_text(block),
        jordan_sizes=block.jordan_sizes,
        basis=basis,
        modulus_sq_expr=block.modulus_sq.expr() if block.modulus_sq else None,
    )
    if (
        block.phase is None
        or block.modulus_sq_float < 1
        and (block.modulus_sq is None or block.modulus_sq.compare_power(1, Fraction(1)) < 0)
    ):
        degenerate = None
        if block.phase is not None:
            degenerate = (
                block.phase.numeric_rank([(0, g) for g in range(len(block.phase.row_groups))]) < block.phase.n_columns
            )
        return BlockReport(
            period=None,
            degenerate=degenerate,
            sigma=None,
            sigma_exact=None,
            rate=None,
            verdict="stable",
            certified=True,
            notes=block.notes,
            **base,
        ), None
    res = compute_sigma(block.phase, channels, budget)
    N = res.period
    lambdas = [ch.bernoulli_lambda for ch in channels]
    all_bernoulli = all(lam is not None and ch.model == "bernoulli" for lam, ch in zip(lambdas, channels))
    notes = list(block.notes) + list(res.notes)
    if res.fully_blind:
        s, exact = compare_rate_bernoulli(block.modulus_sq, block.modulus_sq_float, 1, Fraction(1))
        notes.append("no arrival pattern observes this block (sigma = 1): an unobservable mode")
    elif all_bernoulli and res.bernoulli_exponents is not None:
        lam_f = [lam for lam in lambdas if lam is not None]
        sets = res.maximal_blind_sets or (res.worst_blind_set,)
        c = max(bernoulli_factor(_bernoulli_exponents(F, N, len(channels)), lam_f, N) for F in sets)
        s, exact = compare_rate_bernoulli(block.modulus_sq, block.modulus_sq_float, N, c)
    else:
        sets = res.maximal_blind_sets or (res.worst_blind_set,)
        signs = []
        exact = True
        for F in sets:
            budget.tick("exact transfer matrices")
            si, ex = compare_rate_markov(
                block.modulus_sq, block.modulus_sq_float, N, period_transfer_matrix(N, F, channels, budget)
            )
            signs.append(si)
            exact = exact and ex
        s = max(signs)
    certified = exact and res.certified and block.certified
    verdict = {1: "unstable", 0: "boundary", -1: "stable"}[s]
    if not exact:
        notes.append("rate compared with 1 numerically (50 digits), not exactly")
    report = BlockReport(
        period=N,
        degenerate=res.degenerate,
        sigma=res.sigma,
        sigma_exact=_sigma_exact_text(res, [lam for lam in lambdas if lam is not None]) if all_bernoulli else None,
        rate=block.modulus_sq_float * res.sigma,
        verdict=verdict,
        certified=certified,
        blind_set=sorted([list(s) for s in res.worst_blind_set]),
        notes=tuple(notes),
        bernoulli_blind_fraction=res.bernoulli_exponents if all_bernoulli else None,
        **base,
    )
    return report, res


def _bernoulli_exponents(F: frozenset, N: int, groups: int) -> tuple[Fraction, ...]:
    """``z_g / N``: the share of phases at which group ``g`` is *not* in the blind set ``F``."""
    return tuple(Fraction(N - sum(1 for n, g in F if g == grp), N) for grp in range(groups))


def _critical_probability(blocks: Sequence[BlockReport]) -> tuple[float | None, str | None, list[str]]:
    """Seed 001, Corollary 2 + Theorem 1: ``lambda_c = max_k 1 - beta_k^(-N_k / z_k)``."""
    warnings: list[str] = []
    best: tuple[mpmath.mpf, Any] | None = None
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
        beta = b.modulus_sq_expr if b.modulus_sq_expr is not None else sympy.Float(b.modulus**2, 30)
        expr = 1 - beta ** (-1 / sympy.Rational(share.numerator, share.denominator))
        expr = sympy.nsimplify(expr) if beta.is_Rational else expr
        val = mpmath.mpf(str(sympy.N(expr, 40)))
        if best is None or val > best[0]:
            best = (val, expr)
    if best is None:
        return 0.0, "0", warnings
    if best[0] < 0:
        return 0.0, "0", warnings
    return float(best[0]), str(best[1]), warnings


def _parse_options(request: Request) -> None:
    opts = request.options.get("analyze", {})
    for key in opts:
        raise InvalidInput(f"/options/analyze/{key}", "analyze takes no options")


def analyze(request: Request, budget: Budget | None = None) -> StabilityReport:
    """Decide stability of the expected error covariance (seed 001, Theorem 1).

    Parameters
    ----------
    request:
        A validated request (:func:`analyzer.load_request`).  ``Q`` and ``R``
        are not needed: the verdict does not depend on them.
    budget:
        Work budget; defaults to ``request.time_budget_s`` or 120 s.

    Returns
    -------
    StabilityReport
        ``verdict`` is ``stable`` if ``|alpha_k|^2 sigma_k < 1`` for every FMO
        block, ``unstable`` if ``> 1`` for some block, else ``boundary``.

    Raises
    ------
    AssumptionViolation
        A channel probability of 0 or 1 (seed 001, Assumption 1).
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
    _parse_options(request)
    require_assumption_1(request.channel)
    if budget is None:
        budget = Budget(seconds=request.time_budget_s or DEFAULT_BUDGET_S)
    system = request.system
    channels = _channels_of(request)
    basis = "extension" if len(channels) > 1 else "theorem"
    fmo = fmo_blocks(system, budget)
    analyzed = [_analyze_block(b, channels, basis, budget) for b in fmo]
    blocks = [rep for rep, _ in analyzed]
    verdict = max((b.verdict for b in blocks), key=VERDICTS.index, default="stable")
    warnings: list[str] = []
    assumptions: list[str] = []
    if basis == "extension":
        assumptions.append(
            "per-sensor channels: seed 001's construction applied to separately lost packets "
            "(MATH.md section 3, 'Beyond the seeds'); not a theorem of the seeds"
        )
    crit = crit_exact = None
    if len(channels) == 1 and channels[0].model == "bernoulli":
        crit, crit_exact, w = _critical_probability(blocks)
        warnings.extend(w)
    controllable = _controllable(system)
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
    )
    if basis != "extension":
        return report
    # per-sensor Bernoulli channels: exact critical probability of each sensor, and for two
    # sensors the boundary curve (issue 6; an extension of seed 001, see docs/regions.md)
    regions = region_report(request, budget, report=report, fmo=fmo, sigma=[res for _, res in analyzed])
    return dataclasses.replace(report, regions=regions)


__all__ = ["BlockReport", "StabilityReport", "analyze"]
