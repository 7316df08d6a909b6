"""The tail exponent of the error covariance: ``P(tr P > M) ~ M^(-kappa)``.

Per FMO block ``k`` with ``|alpha_k| > 1``, a blind stretch of ``t`` steps has
probability about ``sigma_k^t`` and multiplies the error along the block by
about ``|alpha_k|^(2t)``, so the stationary distribution of ``P_t`` (which
exists for every arrival rate above 0: Kar, Sinopoli and Moura, 2012) has a
power-law tail with exponent

.. math::

    \\kappa_k = \\frac{\\log(1/\\sigma_k)}{2 \\log|\\alpha_k|}
              = \\frac{\\log(1/\\sigma_k^{N})}{N \\log \\beta_k},
    \\qquad \\kappa = \\min_k \\kappa_k ,

and the moment of order ``r`` of ``P`` is finite iff ``kappa > r``, i.e. iff
``beta_k^r sigma_k < 1`` for every block.  ``r = 1`` is Theorem 1 of Rohr,
Marelli and Fu (2014); ``r = 2`` for i.i.d. losses of a non-degenerate block is
the variance threshold ``lambda > 1 - 1/|alpha|^4`` of Rohr, Marelli and Fu
(2010).  Mo and Sinopoli (2012, Theorems 2-3) prove the power law for
non-degenerate systems with Gilbert-Elliott losses (Bernoulli is the case
``p + q = 1``): those blocks are labelled ``theorem``.  Degenerate blocks,
several packets and channels of order above 1 are kfio's **extension** of the
same argument (``sigma_k`` from the blind-set construction of Rohr, Marelli
and Fu 2014), checked against simulated tails in ``tests/design/test_tail.py``.

Everything is exact where ``sigma_k^N`` is: the moment comparisons are the
exact comparisons of :mod:`kfio.sigma._decide` with ``N`` replaced by
``r N``, and ``kappa_k`` is printed as a rational when it is one.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Sequence

import mpmath
import sympy
from sympy import CRootOf, Poly

from .._reporting import ReportPart
from .._reuse import Memo, kept
from ..model import MarkovChannel
from ..sigma import (
    SigmaResult,
    bernoulli_factor,
    compare_rate_bernoulli,
    compare_rate_markov,
    period_transfer_matrix,
    rho_poly,
    spectral_radius,
)
from ..structure import AlgebraicReal, FmoBlock

THEOREM = "Mo and Sinopoli (2012), IEEE TAC 57(3): power-law tail for non-degenerate systems"
EXTENSION = (
    "kfio's extension of Mo and Sinopoli (2012) to degenerate blocks, several packets or channels of order > 1, "
    "using sigma_k of Rohr, Marelli and Fu (2014); verified against simulated tails"
)
#: Moments whose finiteness is reported by name (any order r follows from kappa > r).
MOMENTS = (("mean", 1), ("variance", 2))
_STATE = {-1: "finite", 0: "boundary", 1: "infinite"}


@dataclass(frozen=True)
class BlockTail(ReportPart):
    """The tail exponent of one FMO block with ``|alpha| > 1``.

    Attributes
    ----------
    eigenvalues:
        Exact texts of the block's eigenvalues.
    kappa, kappa_exact:
        ``log(1/sigma) / (2 log|alpha|)`` as a float and as exact text (``None``
        when ``sigma`` is only known numerically).
    sigma_exact:
        ``sigma`` as exact text (a rational, a radical or ``CRootOf(...)**(1/N)``).
    moments:
        ``{"mean": "finite" | "boundary" | "infinite", "variance": ...}``.
    exact:
        Every moment comparison was decided in exact arithmetic.
    basis, reference:
        ``"theorem"`` (Mo and Sinopoli, 2012) or ``"extension"``, and why.
    """

    eigenvalues: tuple[str, ...]
    kappa: float
    kappa_exact: str | None
    sigma_exact: str | None
    moments: dict[str, str]
    exact: bool
    basis: str
    reference: str


@dataclass(frozen=True)
class TailReport(ReportPart):
    """``kappa = min_k kappa_k`` and the moments it implies.

    Attributes
    ----------
    kappa, kappa_exact:
        The overall exponent (``None`` when no block has ``|alpha| > 1``: no
        power-law tail).
    moments:
        Finiteness of the mean and the variance of the stationary ``P``.
    statement:
        The same in words, e.g. ``"mean bounded, variance unbounded"``.
    blocks:
        One :class:`BlockTail` per block with ``|alpha| > 1``.
    basis:
        ``"theorem"`` if every block's is, else ``"extension"``.
    notes:
        Blocks that contribute no power law (``|alpha| = 1``).
    """

    kappa: float | None
    kappa_exact: str | None
    moments: dict[str, str]
    statement: str
    blocks: tuple[BlockTail, ...]
    basis: str
    notes: tuple[str, ...] = ()

    @classmethod
    def kappa_only(cls, kappa: float | None) -> TailReport:
        """A tail report carrying ``kappa`` (:func:`tail_kappa`) and nothing else: the moments were not computed.

        For a sweep row, which prints ``kappa`` alone
        (:func:`kfio.stability.analyze` with ``tail="kappa"``); its statement says so.
        """
        return cls(
            kappa=kappa,
            kappa_exact=None,
            moments={},
            statement="tail exponent only: the moments were not computed",
            blocks=(),
            basis="not computed",
        )

    def summary_lines(self) -> list[str]:
        """Lines for the terminal summary."""
        if self.kappa is None:
            return [f"tail: {self.statement}"]
        from .._numbers import summary_number

        kappa = summary_number(self.kappa_exact, self.kappa)
        return [f"tail exponent kappa = {kappa}: P(trace P > M) ~ M^-kappa; {self.statement}  [{self.basis}]"]


def _rational_ratio(num: Fraction, den: Fraction) -> Fraction | None:
    """``log(num) / log(den)`` if it is a rational with a small denominator, else ``None`` (exact test)."""
    if num <= 0 or den <= 0 or den == 1:
        return None
    # logs of the integer parts: math.log takes any int, so no float overflow for huge rationals
    log_num = math.log(num.numerator) - math.log(num.denominator)
    log_den = math.log(den.numerator) - math.log(den.denominator)
    guess = Fraction(log_num / log_den).limit_denominator(64)
    a, b = guess.numerator, guess.denominator
    if abs(a) > 256:
        return None
    # log(num) / log(den) = a / b  iff  num^b = den^a
    lhs = num**b
    rhs = den**a if a >= 0 else 1 / den ** (-a)
    return guess if lhs == rhs else None


def _largest_real_root(P: Sequence[Sequence[Fraction]]) -> Any:
    """``rho(P)`` exactly: a Rational, or ``CRootOf`` of the irreducible factor holding it."""
    chi = rho_poly(P)
    best, best_val = None, None
    for factor, _ in chi.factor_list()[1]:
        n = factor.count_roots()
        if n == 0:
            continue
        root = CRootOf(Poly(factor, chi.gen), n - 1)
        val = root.evalf(30)
        if best_val is None or val > best_val:
            best, best_val = root, val
    if best is None:  # pragma: no cover - a non-negative matrix has a real Perron root
        return sympy.Integer(0)
    return sympy.nsimplify(best) if best.is_rational else best


def _worst_set(res: SigmaResult, channels: Sequence[MarkovChannel]) -> frozenset[tuple[int, int]]:
    sets = res.maximal_blind_sets or (res.worst_blind_set,)
    if len(sets) == 1:
        return sets[0]
    return max(sets, key=lambda F: spectral_radius(period_transfer_matrix(res.period, F, channels), 20))


def _worst_factor(
    res: SigmaResult, channels: Sequence[MarkovChannel], lambdas: Sequence[Fraction] | None
) -> tuple[Fraction | None, Any, list[list[Fraction]] | None]:
    """``sigma^N`` of the worst blind set: ``(rational or None, SymPy expression or None, P_F or None)``.

    The expression is ``None`` when the rational is known (the caller builds
    it only if it prints it); ``P_F`` is returned when the moment comparisons
    need the matrix (its Perron root is not rational).
    """
    N = res.period
    if res.fully_blind:
        return Fraction(1), None, None
    if lambdas is not None and res.bernoulli_exponents is not None:
        return bernoulli_factor(res.bernoulli_exponents, lambdas, N), None, None
    worst = _worst_set(res, channels)
    P = period_transfer_matrix(N, worst, channels)
    if len(channels) == 1 and channels[0].order <= 1 and len(worst) < N:
        # a loss resets an order-1 history: P_F has rank one and rho(P_F) = trace(P_F), a rational
        return sum((P[i][i] for i in range(len(P))), Fraction(0)), None, None
    c_expr = _largest_real_root(P)
    c_rational = Fraction(int(c_expr.p), int(c_expr.q)) if c_expr.is_Rational else None
    return c_rational, c_expr, P


def _kappa_float(block: FmoBlock, N: int, c_rational: Fraction | None, c_expr: Any, memo: Memo | None) -> float:
    """``log(1 / sigma^N) / (N log beta)`` at 40 digits, rounded to a float (``log beta`` kept in ``memo``)."""
    beta = block.modulus_sq
    with mpmath.workdps(40):
        if c_rational is not None:
            log_c = _log_rational(c_rational)  # the same mpf as log(mpf(p) / q) at 40 digits
        else:
            log_c = mpmath.log(mpmath.mpf(str(sympy.N(c_expr, 40))))
        log_b = kept(  # the block alone
            memo,
            "log_beta",
            lambda: mpmath.log(beta.approx(40) if beta is not None else mpmath.mpf(block.modulus_sq_float)),
        )
        return float(-log_c / (N * log_b))


@functools.lru_cache(maxsize=4096)
def _log_rational(c: Fraction) -> mpmath.mpf:
    """``log c`` at 40 digits for a rational ``c``, kept per exact ``c`` (a sweep repeats its probabilities on many plants)."""
    with mpmath.workdps(40):
        return mpmath.log(mpmath.mpf(c.numerator) / c.denominator)


def _label(block_degenerate: bool, channels: Sequence[MarkovChannel]) -> tuple[str, str]:
    if not block_degenerate and len(channels) == 1 and channels[0].order <= 1:
        return "theorem", THEOREM
    return "extension", EXTENSION


def block_tail(
    block: FmoBlock,
    res: SigmaResult,
    channels: Sequence[MarkovChannel],
    lambdas: Sequence[Fraction] | None,
    memo: Memo | None = None,
) -> BlockTail:
    """The tail exponent of one block with ``|alpha| > 1`` (Mo and Sinopoli, 2012; kfio's extension).

    .. math::

        \\kappa_k = \\frac{\\log(1 / \\sigma_k^N)}{N \\log \\beta_k}, \\qquad
        E[P^r] < \\infty \\iff \\beta_k^{rN} \\sigma_k^N < 1 .

    Parameters
    ----------
    block:
        The FMO block (``|alpha| > 1``).
    res:
        Its :func:`~kfio.sigma._sigma.compute_sigma` result for ``channels``.
    channels:
        One channel per row group.
    lambdas:
        The arrival probabilities when every channel is Bernoulli, else ``None``.
    memo:
        A dict kept for this ``block`` alone across channels: ``log beta_k``
        (40 digits), which depends on the block only, is kept in it.

    Examples
    --------
    ``A = 2``, ``C = 1``, Bernoulli ``1/2``: ``kappa = log 2 / log 4 = 1/2``.

    >>> from fractions import Fraction
    >>> from kfio import load_request
    >>> from kfio.structure import fmo_blocks
    >>> from kfio.stability import compute_sigma
    >>> from kfio.design._tail import block_tail
    >>> req = load_request('{"system": {"A": [[2]], "C": [[1]]}, '
    ...                    '"channel": {"model": "bernoulli", "arrival_probability": "1/2"}}')
    >>> blk = fmo_blocks(req.system)[0]
    >>> t = block_tail(blk, compute_sigma(blk.phase, [req.channel]), [req.channel], [Fraction(1, 2)])
    >>> t.kappa_exact, t.moments
    ('1/2', {'mean': 'infinite', 'variance': 'infinite'})
    """
    N = res.period
    beta = block.modulus_sq
    basis, reference = _label(res.degenerate, channels)
    c_rational, c_expr, P = _worst_factor(res, channels, lambdas)
    if c_expr is None:
        assert c_rational is not None
        c_expr = sympy.Rational(c_rational.numerator, c_rational.denominator)
    moments, exact = {}, True
    for name, r in MOMENTS:
        if P is None:
            assert c_rational is not None
            sign, ex = compare_rate_bernoulli(beta, block.modulus_sq_float, r * N, c_rational)
        else:
            sign, ex = compare_rate_markov(beta, block.modulus_sq_float, r * N, P)
        moments[name] = _STATE[sign]
        exact = exact and ex
    kappa = _kappa_float(block, N, c_rational, c_expr, memo)
    kappa_exact: str | None = None
    if c_rational is not None and beta is not None and beta.rational is not None:
        ratio = _rational_ratio(1 / c_rational, beta.rational**N) if c_rational != 1 else Fraction(0)
        kappa_exact = _text(ratio) if ratio is not None else None
    if kappa_exact is None and beta is not None:
        if c_rational is not None and beta.rational is not None and c_rational < 1 < beta.rational:
            kappa_exact = log_ratio_text(1 / c_rational, beta.rational, N)
        elif c_rational is not None and 0 < c_rational < 1 and beta.root_text() is not None:
            kappa_exact = log_root_ratio_text(1 / c_rational, beta, N)
        else:
            beta_expr = beta.expr()
            kappa_exact = str(sympy.log(1 / c_expr) / (N * sympy.log(beta_expr)))
    if N == 1 and c_rational is not None:
        sigma_exact = _text(c_rational)
    else:
        sigma_exact = str(c_expr ** sympy.Rational(1, N))
    return BlockTail(
        eigenvalues=block.eigenvalue_texts,
        kappa=kappa,
        kappa_exact=kappa_exact,
        sigma_exact=sigma_exact,
        moments=moments,
        exact=exact,
        basis=basis,
        reference=reference,
    )


def log_ratio_text(x: Fraction, b: Fraction, N: int) -> str:
    """The text of ``log(x) / (N log(b))`` for rationals ``x, b > 1``, as SymPy prints it.

    SymPy's ``log`` of a number tries the complex and algebraic rewritings of
    its argument before it leaves ``log(x)`` alone (about 2.5 ms for
    ``log(1000000/399993)``, most of an uncached analysis of a small system);
    for ``x > 1`` rational none applies, so the text is built directly.
    ``tests/design/test_tail.py`` checks it against SymPy's, character for character.

    Examples
    --------
    >>> from fractions import Fraction
    >>> log_ratio_text(Fraction(1000000, 399993), Fraction(25, 16), 1)
    'log(1000000/399993)/log(25/16)'
    >>> log_ratio_text(Fraction(4), Fraction(2), 3)
    'log(4)/(3*log(2))'
    """
    if not (x > 1 and b > 1 and N >= 1):
        raise ValueError(f"log_ratio_text needs x > 1, b > 1 and N >= 1, not x = {x}, b = {b}, N = {N}")
    if x == b:  # the one case SymPy's product cancels: log(b) / (N log(b)) = 1/N
        return _text(Fraction(1, N))
    den = f"log({_text(b)})" if N == 1 else f"({N}*log({_text(b)}))"
    return f"log({_text(x)})/{den}"


def log_root_ratio_text(x: Fraction, beta: AlgebraicReal, N: int) -> str:
    """SymPy's text of ``log(x) / (N log(beta))`` for a rational ``x > 1`` and an irrational ``beta`` printed as a plain ``CRootOf``.

    As :func:`log_ratio_text`, without building SymPy's expression (the root's
    text is :meth:`AlgebraicReal.root_text`); ``tests/design/test_tail.py``
    checks it against SymPy's text.
    """
    root = beta.root_text()
    if not (x > 1 and N >= 1 and root is not None):
        raise ValueError(f"log_root_ratio_text needs x > 1, N >= 1 and a CRootOf text, not x = {x}, N = {N}")
    den = f"log({root})" if N == 1 else f"({N}*log({root}))"
    return f"log({_text(x)})/{den}"


def _text(x: Fraction) -> str:
    return str(x.numerator) if x.denominator == 1 else f"{x.numerator}/{x.denominator}"


def _statement(moments: dict[str, str]) -> str:
    words = {"finite": "bounded", "infinite": "unbounded", "boundary": "on the boundary"}
    return ", ".join(f"{name} {words[state]}" for name, state in moments.items())


def _bernoulli_lambdas(channels: Sequence[MarkovChannel]) -> list[Fraction] | None:
    """The arrival probabilities when every channel is Bernoulli (order 0), else ``None``."""
    lambdas = [ch.bernoulli_lambda for ch in channels]
    if all(lam is not None and ch.order == 0 for lam, ch in zip(lambdas, channels)):
        return [lam for lam in lambdas if lam is not None]
    return None


def _on_circle(block: FmoBlock, memo: Memo | None) -> bool:
    """``|alpha_k| = 1``, exactly when ``beta_k`` is known exactly (a property of the block alone, kept in ``memo``)."""
    beta = block.modulus_sq
    return bool(
        kept(
            memo,
            "on_circle",
            lambda: beta.compare_power(1, Fraction(1)) == 0 if beta is not None else block.modulus_sq_float == 1.0,
        )
    )


def tail_kappa(
    items: Sequence[tuple[FmoBlock, SigmaResult | None]],
    channels: Sequence[MarkovChannel],
    memo: Sequence[Memo] | None = None,
) -> float | None:
    """``kappa = min_k kappa_k`` alone: the float :func:`tail_report` gives as ``TailReport.kappa``.

    A sweep row prints this one number of the tail report (Mo and Sinopoli
    (2012); ``kappa_k = log(1 / sigma_k^N) / (N log beta_k)`` over the blocks
    with ``|alpha_k| > 1``).  It is computed by the same code as
    :func:`block_tail`'s ``kappa`` (:func:`_worst_factor`, then
    :func:`_kappa_float` at 40 digits), so it is the same float; what the row
    does not print (the exact comparisons of the two moments, ``kappa`` as
    exact text, ``sigma`` as text) is skipped.  ``None`` when no block has
    ``|alpha_k| > 1``.  ``tests/design/test_tail_kappa.py`` checks it equal
    to ``tail_report(...).kappa`` on every kind of channel.
    """
    bern = _bernoulli_lambdas(channels)
    kappas: list[float] = []
    for i, (block, res) in enumerate(items):
        if res is None:
            continue
        block_memo = None if memo is None else memo[i]
        if _on_circle(block, block_memo):
            continue
        c_rational, c_expr, _ = _worst_factor(res, channels, bern)
        kappas.append(_kappa_float(block, res.period, c_rational, c_expr, block_memo))
    return min(kappas) if kappas else None


def tail_report(
    items: Sequence[tuple[FmoBlock, SigmaResult | None]],
    channels: Sequence[MarkovChannel],
    memo: Sequence[Memo] | None = None,
) -> TailReport:
    """Tail exponents of every block with ``|alpha| > 1`` and the overall ``kappa = min_k kappa_k``.

    Parameters
    ----------
    items:
        ``(block, sigma result)`` for every FMO block, as :func:`kfio.analyze`
        computed them (``None`` for blocks inside the unit circle).
    channels:
        One channel per row group.
    memo:
        One dict per item, kept for its block alone across channels (see
        :func:`block_tail`); whether ``|alpha_k| = 1`` is kept there too.

    Returns
    -------
    TailReport
        The overall moments are the worst over blocks (a moment is finite iff
        it is finite for every block).
    """
    bern = _bernoulli_lambdas(channels)
    tails: list[BlockTail] = []
    notes: list[str] = []
    for i, (block, res) in enumerate(items):
        if res is None:
            continue
        block_memo = None if memo is None else memo[i]
        on_circle = _on_circle(block, block_memo)
        if on_circle:
            notes.append(
                f"block {', '.join(block.eigenvalue_texts)} has |alpha| = 1: blind stretches grow the error "
                "polynomially, not geometrically; it contributes no power-law tail"
            )
            continue
        tails.append(block_tail(block, res, channels, bern, block_memo))
    if not tails:
        return TailReport(
            kappa=None,
            kappa_exact=None,
            moments={name: "finite" for name, _ in MOMENTS} if not notes else {},
            statement="no block with |alpha| > 1: no power-law tail",
            blocks=(),
            basis="theorem",
            notes=tuple(notes),
        )
    worst = min(tails, key=lambda t: t.kappa)
    order = list(_STATE.values())
    moments = {name: max((t.moments[name] for t in tails), key=order.index) for name, _ in MOMENTS}
    return TailReport(
        kappa=worst.kappa,
        kappa_exact=worst.kappa_exact,
        moments=moments,
        statement=_statement(moments),
        blocks=tuple(tails),
        basis="theorem" if all(t.basis == "theorem" for t in tails) else "extension",
        notes=tuple(notes),
    )


__all__ = ["BlockTail", "TailReport", "block_tail", "tail_kappa", "tail_report"]
