"""The critical value of one link's parameter, the other links fixed: exact for rational data.

For a Bernoulli link with arrival probability ``x`` (or a Gilbert-Elliott
link's recovery rate ``x``) every transition probability of the joint chain
is affine in ``x``, so the second-moment operator is ``T(x) = T(x0) + (x - x0) T1``.
``rho(T(x))`` is continuous in ``x`` and is an eigenvalue of ``T(x)`` (a
positive map: Costa, Fragoso and Marques 2005, Ch. 3), so it can cross 1
only at a root of ``f(x) = det(I - T(x))``.  With ``A0 = I - T(x0)``
invertible, ``f(x) = det(A0) det(I - (x - x0) A0^(-1) T1)``: the reversed
characteristic polynomial of ``A0^(-1) T1`` (FLINT), shifted.  Its real
roots in ``(0, 1)`` are isolated with certified Arb balls, and the verdict
on each interval between consecutive roots is decided exactly at a rational
point (:func:`kfio.loop._verdict.decide`).  The critical value is the left
end of the stable interval that reaches 1.

Where the exact route is slow (large operators of long data, :func:`exact_critical`),
the answer is a certified bracket instead: bisection on verdicts each proved
by the float certificates of :mod:`kfio.loop._certify` (stable at the upper
end, unstable at the lower one), labelled as a bracket.  A link that does not
enter the operator at all (``T(x)`` constant, e.g. ``C = 0`` for the sensor or
``L = 0`` for the actuator) has no critical value: the verdict is the same at
every value, and the note says so.

This is a computation on the given design (fixed gains), not a theorem about
the optimal design (Schenato, Sinopoli, Franceschetti, Poolla and Sastry
2007, Sec. V, give the latter for TCP-like LQG).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Callable

import flint

from .._budget import Budget
from ..errors import NumericalFailure
from ..model import MAX_EXACT_DIGITS, MarkovChannel, fraction_digits, fraction_text
from ._algebraic import root_text
from ._certify import certify
from ._mjls import Branch, Mjls
from ._operator import operator_matrix
from ._pencil import det_polynomial_of
from ._verdict import SHORT_DATA_BITS, data_bits, decide

#: Largest operator size for which the exact critical value is computed.
MAX_CRITICAL_SIZE = 200
#: Operator sizes whose exact critical value is computed whatever the data: for data read from floats
#: 0.26 s at size 36, 0.53 s at 55, 2.2 s at 78 (a certified bracket: 0.1 s, docs/speed.md); beyond, only
#: for short data (:data:`SHORT_DATA_BITS`).
EXACT_CRITICAL_SIZE = 60
#: Width at which the certified bisection stops (each step is one dense float solve and its proof).
BRACKET_WIDTH = Fraction(1, 256)
#: Operator size above which the bisection stops at :data:`WIDE_BRACKET_WIDTH` instead.
WIDE_BRACKET_SIZE = 1000
WIDE_BRACKET_WIDTH = Fraction(1, 32)


@dataclass(frozen=True)
class Critical:
    """The critical value of one parameter and the exact labels of the intervals of ``(0, 1)``.

    ``polynomial`` (integer coefficients, constant first) is the irreducible
    polynomial over Q of which the critical value is a root, ``enclosure`` a
    certified interval around it holding no other root: together an exact
    description, also when ``exact`` (a rational or quadratic text) is ``None``.
    """

    link: str
    parameter: str
    value: float | None
    exact: str | None
    intervals: tuple[tuple[float, float, str], ...]
    note: str
    polynomial: tuple[str, ...] | None = None
    enclosure: tuple[float, float] | None = None
    degree: int | None = None
    coefficient_digits: int | None = None
    bracket: tuple[Fraction, Fraction] | None = None

    def as_dict(self) -> dict[str, object]:
        return {
            "link": self.link,
            "parameter": self.parameter,
            "value": self.value,
            "value_exact": self.exact,
            "value_minimal_polynomial": list(self.polynomial) if self.polynomial is not None else None,
            "value_minimal_polynomial_degree": self.degree,
            "value_minimal_polynomial_digits": self.coefficient_digits,
            "value_enclosure": list(self.enclosure) if self.enclosure is not None else None,
            "value_bracket": [float(x) for x in self.bracket] if self.bracket is not None else None,
            "value_bracket_exact": [fraction_text(x) for x in self.bracket] if self.bracket is not None else None,
            "intervals": [{"from": a, "to": b, "verdict": v} for a, b, v in self.intervals],
            "note": self.note,
        }


#: The parameter a link's critical value varies, by channel model.
LINK_PARAMETER = {"bernoulli": "arrival_probability", "gilbert_elliott": "recovery_rate"}


def parameter_of(pointer: str, ch: MarkovChannel) -> tuple[str, Callable[[Fraction], MarkovChannel]] | None:
    """The parameter varied for a link, and the channel at a value; ``None`` when not defined.

    The parameter's table entries come from the core's channel-parameter parser
    (:func:`kfio.design.channel_parameter`, the one of ``options.analyze.critical_parameter``).
    """
    from ..design import channel_parameter

    name = LINK_PARAMETER.get(ch.model)
    found = None if name is None else channel_parameter(ch, [name])
    if name is None or found is None:
        return None
    entries, complement, _ = found

    def at(x: Fraction) -> MarkovChannel:
        table = list(ch.table)
        for e in entries:
            table[e] = 1 - x if complement else x
        return dataclasses.replace(ch, table=tuple(table), params={**ch.params, name: x})

    return f"{pointer}/{name}", at


def _text(f: flint.fmpz_poly, ball: flint.arb) -> str | None:
    return root_text(f, float(ball.mid()))


def _between(a: flint.arb, b: flint.arb) -> Fraction:
    """A rational strictly between two disjoint real balls ``a < b``."""
    return (_exact(a.upper()) + _exact(b.lower())) / 2


def _exact(x: flint.arb) -> Fraction:
    """The value of an exact ball (an endpoint), as a Fraction."""
    man, exp = (int(v) for v in x.man_exp())
    return Fraction(man) * Fraction(2) ** exp


def roots_in_unit(poly: flint.fmpq_poly) -> list[tuple[flint.arb, flint.fmpz_poly]]:
    """Real roots of ``poly`` strictly inside ``(0, 1)``: certified isolating balls, ascending, with their factor."""
    out: list[tuple[flint.arb, flint.fmpz_poly]] = []
    if poly.degree() < 1:
        return out
    _, factors = poly.numer().factor()
    zero, one = flint.arb(0), flint.arb(1)
    old = flint.ctx.prec
    try:
        for f, _ in factors:
            if f.degree() < 1 or f(0) == 0 or f(1) == 0:
                continue  # roots 0 and 1 are the ends of the range, not inside it
            flint.ctx.prec = 128
            while True:
                found: list[Any] = f.complex_roots()
                balls = [z.real for z, _m in found if z.imag.is_exact() and z.imag.is_zero()]
                if all(r > zero or r < zero for r in balls) and all(r > one or r < one for r in balls):
                    break
                if flint.ctx.prec > 1 << 14:
                    raise NumericalFailure("a root of det(I - T(x)) could not be separated from 0 or 1")
                flint.ctx.prec *= 4
            out += [(r, f) for r in balls if r > zero and r < one]
    finally:
        flint.ctx.prec = old
    out.sort(key=lambda t: float(t[0].mid()))
    return out


def _tick(budget: Budget | None, what: str) -> None:
    if budget is not None:
        budget.tick(what)


def det_polynomial(build: Callable[[Fraction], Mjls], budget: Budget | None = None) -> flint.fmpq_poly | None:
    """``det(I - T(x))`` up to a non-zero constant, as a polynomial in ``x`` (see the module docstring).

    ``T(x) = T(1/3) + (x - 1/3) T1`` with ``T1 = 3 (T(2/3) - T(1/3))``; the determinant of the
    affine pencil is computed multimodularly (:mod:`kfio.loop._pencil`).
    """
    x0, x1 = Fraction(1, 3), Fraction(2, 3)
    _tick(budget, "critical value: exact operators")
    T0 = operator_matrix(build(x0))
    T1 = (operator_matrix(build(x1)) - T0) * 3  # slope of the affine map
    return det_polynomial_of(T0 - flint.fmpq(1, 3) * T1, T1, budget)  # T(x) = T(0) + x T1


def det_polynomial_rational(build: Callable[[Fraction], Mjls]) -> flint.fmpq_poly | None:
    """The same polynomial by the rational route: ``A0^-1 T1`` over Q and its characteristic polynomial.

    Kept as an independent check of :func:`det_polynomial` (tests, ``bench/bench_loop.py``): its
    entries carry denominators of ``det(A0)``'s size, which is what limits it to small operators.
    """
    x0, x1 = Fraction(1, 3), Fraction(2, 3)
    T0 = operator_matrix(build(x0))
    T1 = (operator_matrix(build(x1)) - T0) * 3  # slope of the affine map
    size = T0.nrows()
    eye = flint.fmpq_mat(size, size)
    for i in range(size):
        eye[i, i] = 1
    for base in (x0, Fraction(1, 2), Fraction(1, 5), Fraction(4, 5), Fraction(1, 7), Fraction(6, 7)):
        A0 = eye - T0 - flint.fmpq((base - x0).numerator, (base - x0).denominator) * T1
        try:
            Bm = A0.solve(T1)
        except ZeroDivisionError:
            continue
        chi = Bm.charpoly()  # det(mu I - B), degree size
        coeffs = list(chi.coeffs()) + [flint.fmpq(0)] * (size + 1 - len(chi.coeffs()))
        rev = flint.fmpq_poly(list(reversed(coeffs)))  # det(I - y B)
        shift = flint.fmpq_poly([flint.fmpq(-base.numerator, base.denominator), 1])  # y = x - base
        return rev(shift)
    return None


def critical_value(
    label: str,
    pointer: str,
    ch: MarkovChannel,
    build: Callable[[MarkovChannel], Mjls],
    budget: Budget | None = None,
) -> Critical:
    """The exact critical value of the link's parameter (see the module docstring).

    ``budget`` (:class:`kfio.Budget`) is checked between the exact steps; :class:`kfio.errors.BudgetExceeded`
    when it is spent.
    """
    par = parameter_of(pointer, ch)
    if par is None:
        return Critical(label, pointer, None, None, (), f"not defined for a {ch.model} channel of order {ch.order}")
    parameter, at = par

    def system(x: Fraction) -> Mjls:
        return build(at(x))

    half = system(Fraction(1, 2))
    if not _link_enters(system):
        verdict = decide(half, budget).verdict
        return Critical(
            label,
            parameter,
            None,
            None,
            ((0.0, 1.0, verdict),),
            f"the link has no effect on the loop (its packets change no mode map): the verdict is {verdict} "
            "at every value, so no critical value exists",
        )
    if not exact_critical(half):
        return certified_bracket(label, parameter, system, budget)
    poly = det_polynomial(system, budget)
    if poly is None:
        return Critical(
            label,
            parameter,
            None,
            None,
            (),
            "1 is an eigenvalue of T(x) at every value (det(I - T(x)) = 0 identically), so rho(T(x)) >= 1 and "
            "no value makes the loop mean-square stable",
        )
    roots = roots_in_unit(poly)
    edges: list[tuple[flint.fmpz_poly | None, float, str | None, flint.arb | None]] = [(None, 0.0, "0", None)]
    for r, f in roots:
        edges.append((f, float(r.mid()), _text(f, r), r))
    edges.append((None, 1.0, "1", None))
    labels = []
    for k in range(len(edges) - 1):
        a, b = edges[k], edges[k + 1]
        lo = flint.arb(0) if a[3] is None else a[3]
        hi = flint.arb(1) if b[3] is None else b[3]
        mid = _between(lo, hi)
        labels.append(decide(system(mid), budget).verdict)
    merged: list[tuple[float, float, str]] = []
    for k, lab in enumerate(labels):  # spurious roots (another eigenvalue crossing 1) join their neighbours
        if merged and merged[-1][2] == lab:
            merged[-1] = (merged[-1][0], edges[k + 1][1], lab)
        else:
            merged.append((edges[k][1], edges[k + 1][1], lab))
    intervals = tuple(merged)
    if labels[-1] != "stable":
        return Critical(label, parameter, None, None, intervals, "no value near 1 makes the loop mean-square stable")
    k = len(labels) - 1
    while k > 0 and labels[k - 1] == "stable":
        k -= 1
    left = edges[k]
    note = "exact: a root of det(I - T(x)), the stable side decided exactly"
    minimal, degree, digits = _minimal(left[0])
    ball = left[3]
    box = (float(_exact(ball.lower())), float(_exact(ball.upper()))) if ball is not None else None
    return Critical(label, parameter, left[1], left[2], intervals, note, minimal, box, degree, digits)


def _minimal(f: flint.fmpz_poly | None) -> tuple[tuple[str, ...] | None, int | None, int | None]:
    """The coefficient texts (``None`` when one passes the report's 200-digit cap), degree and longest digits."""
    if f is None:
        return None, None, None
    coeffs = [int(c) for c in f.coeffs()]
    digits = max(fraction_digits(Fraction(c)) for c in coeffs)
    texts = tuple(str(c) for c in coeffs) if digits <= MAX_EXACT_DIGITS else None
    return texts, f.degree(), digits


def _link_enters(system: Callable[[Fraction], Mjls]) -> bool:
    """Whether the operator may depend on the link's parameter (``T`` is affine in it).

    ``False`` only when, at ``1/3`` and ``2/3``, the transition laws agree and every mode has the same
    maps with the same total weight each: then ``T(1/3) = T(2/3)`` and ``T`` is constant.
    """
    a, b = system(Fraction(1, 3)), system(Fraction(2, 3))
    if a.P != b.P:
        return True

    def grouped(branches: tuple[Branch, ...]) -> list[tuple[flint.fmpq_mat, Fraction]]:
        out: list[tuple[flint.fmpq_mat, Fraction]] = []
        for br in branches:
            for k, (M, w) in enumerate(out):
                if M == br.M:
                    out[k] = (M, w + br.weight)
                    break
            else:
                out.append((br.M, br.weight))
        return out

    for ra, rb in zip(a.branches, b.branches):
        ga, gb = grouped(ra), grouped(rb)
        if len(ga) != len(gb) or any(not any(M == N and w == v for N, v in gb) for M, w in ga):
            return True
    return False


def exact_critical(sys: Mjls) -> bool:
    """Whether the exact critical value is fast here: a small operator, or short data (:data:`EXACT_CRITICAL_SIZE`)."""
    size = sys.modes * sys.d * (sys.d + 1) // 2
    return size <= EXACT_CRITICAL_SIZE or (size <= MAX_CRITICAL_SIZE and data_bits(sys) <= SHORT_DATA_BITS)


def certified_bracket(
    label: str, parameter: str, system: Callable[[Fraction], Mjls], budget: Budget | None = None
) -> Critical:
    """A bracket ``[lo, hi]`` of the critical value by bisection on verdicts proved in floats (module docstring).

    ``hi`` is proved stable and ``lo`` unstable (or ``lo = 0``): under the assumption that the stable
    set is the interval from the critical value to 1, the critical value lies in ``[lo, hi]``.
    """
    route = "certified bracket (verified float certificates, Rump 2006)"

    def verdict(x: Fraction) -> str | None:
        _tick(budget, "critical value: certified bisection")
        return certify(system(x), enclose=False).verdict

    top = verdict(Fraction(1))
    if top != "stable":
        why = "the loop is proved unstable at 1" if top == "unstable" else "the verdict at 1 is not certified"
        return Critical(label, parameter, None, None, (), f"{route}: {why}, so no value near 1 makes it stable")
    lo, hi = Fraction(0), Fraction(1)
    one = system(Fraction(1))
    width = WIDE_BRACKET_WIDTH if one.modes * one.d * (one.d + 1) // 2 > WIDE_BRACKET_SIZE else BRACKET_WIDTH
    seen_unstable = False
    if verdict(Fraction(0)) == "stable":
        hi = Fraction(0)
    while hi - lo > width:
        step = (hi - lo) / 8
        for mid in ((lo + hi) / 2, (lo + hi) / 2 - step, (lo + hi) / 2 + step):
            v = verdict(mid)  # a point within rounding of rho = 1 (a dyadic critical value) decides nothing
            if v is not None:
                break
        if v == "stable":
            hi = mid
        elif v == "unstable":
            lo, seen_unstable = mid, True
        else:
            break  # three points near rho = 1: the bracket stays as proved
    lower = f"unstable at {float(lo):.6g}" if seen_unstable else f"not proved unstable above {float(lo):.6g}"
    note = (
        f"{route}: the loop is proved mean-square stable at {float(hi):.6g} and {lower}; the critical value "
        f"lies in [{float(lo):.6g}, {float(hi):.6g}] if the stable set is one interval reaching 1 (the exact "
        "value is computed for operators of size at most "
        f"{EXACT_CRITICAL_SIZE}, or {MAX_CRITICAL_SIZE} with short data)"
    )
    return Critical(label, parameter, None, None, (), note, bracket=(lo, hi))


__all__ = [
    "Critical",
    "MAX_CRITICAL_SIZE",
    "certified_bracket",
    "exact_critical",
    "critical_value",
    "det_polynomial",
    "det_polynomial_rational",
    "parameter_of",
    "roots_in_unit",
]
