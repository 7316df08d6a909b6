"""Exact verdicts along a line of channel parameters: intervals, labels and the critical values between them.

Shared by the Gilbert-Elliott region (:mod:`kfio.design._ge_region`) and the
critical value of one Markov parameter (:mod:`kfio.design._critical_parameter`).
Every candidate critical value is a real root in ``(0, 1)`` of some boundary
polynomial over ``Q`` (an exact ``CRootOf`` or rational); the label of each
interval between consecutive candidates is decided exactly at a rational
point inside it; a critical value is a candidate where the label changes.
Spurious candidates (a root where another eigenvalue, not the Perron root,
crosses) are harmless: the labels on both sides agree and it is dropped.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Callable, Generic, Sequence, TypeVar

import mpmath
import sympy

T = TypeVar("T")


@dataclass(frozen=True)
class Candidate(Generic[T]):
    """A possible critical value and the constraints (tags) whose boundary passes through it."""

    value: mpmath.mpf
    exact: Any
    tags: list[T]


@dataclass(frozen=True)
class Change(Generic[T]):
    """A critical value: the label is ``left`` just below and ``right`` just above."""

    value: float
    exact_text: str | None
    left: str
    right: str
    tag: T | None


def critical_text(text: str | None, value: float) -> str:
    """A critical value in kfio's one number format: ``0.555556 = 5/9``, ``0.487428 (from float data)``."""
    from .._numbers import summary_number
    from ..structure import readable

    return summary_number(text, value, readable=None if text is None else readable(text, value))


def roots_in_unit(poly: Any, var: Any) -> list[Any]:
    """Real roots of ``poly`` (over ``Q``) strictly inside ``(0, 1)``, exact."""
    P = sympy.Poly(poly, var, domain=sympy.QQ)
    if P.degree() <= 0:
        return []
    return [r for r in P.real_roots() if r > 0 and r < 1]


def add_candidates(candidates: list[Candidate[T]], roots: Sequence[Any], tag: T) -> None:
    """Merge exact roots of one constraint into ``candidates`` (equal roots share an entry)."""
    for r in roots:
        for c in candidates:
            if c.exact == r:
                c.tags.append(tag)
                break
        else:
            with mpmath.workdps(60):
                candidates.append(Candidate(mpmath.mpf(str(sympy.N(r, 55))), r, [tag]))


def midpoint(a: mpmath.mpf, b: mpmath.mpf) -> Fraction:
    """A rational strictly between two candidates (separated by far more than ``1e-50``)."""
    with mpmath.workdps(60):
        return Fraction(mpmath.nstr((a + b) / 2, 55, strip_zeros=False))


def exact_text(r: Any) -> str:
    """A rational, a radical for a quadratic ``CRootOf``, else the ``CRootOf`` itself."""
    if r.is_Rational:
        return str(r)
    if isinstance(r, sympy.CRootOf) and sympy.degree(r.poly) <= 2:
        return str(sympy.nsimplify(sympy.simplify(r.expand(func=True))))
    return str(r)


def scan(
    candidates: list[Candidate[T]], label_at: Callable[[Fraction], tuple[str, T | None]]
) -> tuple[tuple[tuple[float, float, str], ...], tuple[Change[T], ...]]:
    """Intervals of ``(0, 1)`` with exact labels, and the changes between them.

    ``label_at(x)`` is the exact verdict at a rational ``x`` and the tag that
    decides it.  At a change, the deciding tag is the one whose boundary
    passes through the point and that decides on the unstable side.
    """
    candidates = sorted(candidates, key=lambda c: c.value)
    edges = [mpmath.mpf(0)] + [c.value for c in candidates] + [mpmath.mpf(1)]
    labels = [label_at(midpoint(a, b)) for a, b in zip(edges[:-1], edges[1:])]
    intervals = tuple((float(a), float(b), lab) for a, b, (lab, _) in zip(edges[:-1], edges[1:], labels))
    changes = []
    for i, c in enumerate(candidates):
        (left, tl), (right, tr) = labels[i], labels[i + 1]
        if left == right:
            continue
        side = tr if right == "unstable" else tl
        tag = side if side in c.tags else (c.tags[0] if c.tags else None)
        changes.append(Change(float(c.value), exact_text(c.exact) if c.exact is not None else None, left, right, tag))
    return intervals, tuple(changes)


__all__ = ["Candidate", "Change", "add_candidates", "exact_text", "midpoint", "roots_in_unit", "scan"]
