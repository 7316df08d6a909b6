"""Confidence intervals of the fitted probabilities: exact binomial per parameter, Bonferroni jointly.

Given its count ``n(h->*)``, the number of arrivals after history ``h`` is
binomial, so each estimate ``n(h->1) / n(h->*)`` gets the exact interval of
Clopper and Pearson (1934) (``scipy.stats.binomtest(...).proportion_ci(method="exact")``),
whose coverage is at least its level for every true value.  A verdict reads
all ``m`` parameters at once; the box of the ``m`` intervals taken each at
level ``1 - (1 - level) / m`` covers all of them together with probability at
least ``level`` (Bonferroni's inequality), whatever their dependence.
"""

from __future__ import annotations

from fractions import Fraction

from scipy import stats


def clopper_pearson(successes: int, trials: int, level: float) -> tuple[float, float]:
    """The exact (Clopper and Pearson 1934) interval of a binomial proportion at ``level``.

    ``[B(a/2; k, n-k+1), B(1-a/2; k+1, n-k)]`` with ``B`` the beta quantile and
    ``a = 1 - level``; the lower end is 0 when ``k = 0`` and the upper end 1 when ``k = n``.
    """
    ci = stats.binomtest(successes, trials).proportion_ci(confidence_level=level, method="exact")
    return float(ci.low), float(ci.high)


def bonferroni_level(level: Fraction, parameters: int) -> Fraction:
    """The level of each of ``parameters`` intervals whose box has joint level ``level``: ``1 - (1 - level) / m``."""
    return 1 - (1 - level) / max(parameters, 1)


def interval_method(level: Fraction, parameters: int) -> str:
    """One sentence saying how the joint level is shared."""
    each = bonferroni_level(level, parameters)
    share = (
        "the one parameter at that level"
        if parameters == 1
        else f"each of the {parameters} parameters at 1 - (1 - {float(level):g}) / {parameters} = {float(each):.6g}"
    )
    return (
        f"exact binomial intervals of Clopper and Pearson (1934), joint at level {float(level):g} by Bonferroni: "
        f"{share}, so the box of the intervals holds every true parameter at once with probability at least "
        f"{float(level):g}"
    )


__all__ = ["bonferroni_level", "clopper_pearson", "interval_method"]
