"""The exact mean-square stability verdict of a loop: ``rho(T)`` below, at or above 1.

``T`` (:mod:`kfio.loop._operator`) is a positive map on ``N`` symmetric
matrices, so ``rho(T)`` is one of its eigenvalues (Krein-Rutman; Costa,
Fragoso and Marques 2005, Ch. 3 and Thm 3.9) and:

* ``rho(T) < 1`` iff the coupled Lyapunov equation ``Y - T(Y) = I`` has a
  solution with every ``Y_i`` positive definite (Thm 3.9).  Solving it
  exactly over ``Q`` decides the verdict and the solution *is* the
  certificate, checked exactly;
* if ``I - T`` is invertible and the solution is not positive definite,
  ``rho(T) > 1`` (``rho`` is an eigenvalue and 1 is not one);
* if ``I - T`` is singular, 1 is an eigenvalue and ``rho(T) >= 1``: the
  characteristic polynomial (FLINT) with the factors ``x - 1`` removed has a
  real root above 1 (isolated with certified Arb balls) iff ``rho > 1``;
  otherwise ``rho = 1``, the boundary.

The exact route is taken where it is fast (:func:`exact_route`: small
operators, or data of small height); elsewhere the verdict is proved from
floats with interval arithmetic (:mod:`kfio.loop._certify`: a verified
Lyapunov certificate for ``stable``, a verified Perron certificate for
``unstable``), as surely as the exact route, with certified enclosures of
``rho(T)`` and of the cost.  Only when neither float certificate verifies
(``rho`` at or within rounding of 1) does the exact route run at any size up
to :data:`MAX_EXACT_SIZE`; above it the verdict is the float one and the
report says it is not certified.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import flint
import numpy as np

from .._budget import Budget
from ..errors import NumericalFailure
from ..model import is_positive_definite
from ._algebraic import root_text
from ._certify import certify
from ._mjls import Mjls
from ._operator import (
    apply_exact,
    float_operator,
    noise_vector,
    operator_matrix,
    unvech,
    vech,
    vech_index,
)

#: Largest operator size (``modes * d (d + 1) / 2``) solved exactly over Q.
MAX_EXACT_SIZE = 1200
#: Operator sizes decided exactly whatever the data (about 0.2 s for data read from floats,
#: ``bench/bench_loop_certify.py``); beyond, exactly only when the data are short (:data:`SHORT_DATA_BITS`).
EXACT_ROUTE_SIZE = 80
#: Largest bit length of a numerator or denominator of the loop's maps for which the exact route
#: runs at any size up to :data:`MAX_EXACT_SIZE` (decimal data of a few digits; a float's text has about 56).
SHORT_DATA_BITS = 40
#: Largest operator size whose exact spectral radius (rational or quadratic) is reported.
MAX_EXACT_RADIUS_SIZE = 24


@dataclass(frozen=True)
class Decision:
    """The verdict, how it was reached, and the exact stationary moments when the loop is stable.

    On the certified route (``exact`` false) ``moments`` is ``None``; ``radius_enclosure`` and
    ``cost_enclosure`` are then proved bounds (Fractions) and ``cost`` the float cost inside them.
    """

    verdict: str
    exact: bool
    certified: bool
    certificate: str
    spectral_radius: float
    spectral_radius_exact: str | None
    size: int
    moments: tuple[flint.fmpq_mat, ...] | None
    radius_enclosure: tuple[Fraction, Fraction] | None = None
    cost: float | None = None
    cost_enclosure: tuple[Fraction, Fraction] | None = None


def _fraction(x: flint.fmpq) -> Fraction:
    return Fraction(int(x.p), int(x.q))


def positive_definite(X: flint.fmpq_mat) -> bool:
    """``X > 0`` exactly, by kfio's one definiteness test (:func:`kfio.model.is_positive_definite`)."""
    return is_positive_definite(tuple(tuple(_fraction(X[i, j]) for j in range(X.ncols())) for i in range(X.nrows())))


def _stacked(sys: Mjls, v: flint.fmpq_mat, col: int) -> list[flint.fmpq_mat]:
    s = len(vech_index(sys.d))
    return [unvech([v[j * s + r, col] for r in range(s)], sys.d) for j in range(sys.modes)]


def _largest_real_root(poly: flint.fmpq_poly) -> tuple[int, str | None]:
    """Sign of ``rho - 1`` for the largest real root of ``poly`` (>= 1 assumed), and its exact text if simple."""
    num = poly.numer()
    _, factors = num.factor()
    best = None
    best_factor = None
    for f, _ in factors:
        if f.degree() < 1:
            continue
        roots: list[Any] = f.complex_roots()
        for z, _mult in roots:
            if z.imag.is_exact() and z.imag.is_zero():
                if best is None or z.real > best:
                    best, best_factor = z.real, f
    if best is None:
        return -1, None
    one = flint.arb(1)
    if best > one:
        sign = 1
    elif best < one:
        sign = -1
    elif best_factor is not None and best_factor.degree() == 1 and best_factor(1) == 0:
        sign = 0
    else:
        raise NumericalFailure("the Perron root could not be separated from 1")
    return sign, _root_text(best_factor, best)


def _root_text(f: flint.fmpz_poly | None, ball: flint.arb) -> str | None:
    return root_text(f, float(ball.mid()))


def exact_radius(sys: Mjls, T: flint.fmpq_mat | None = None) -> tuple[int, str | None]:
    """Sign of ``rho(T) - 1`` and the exact ``rho`` (rational or quadratic) from the characteristic polynomial."""
    T = T if T is not None else operator_matrix(sys)
    return _largest_real_root(T.charpoly())


def rounded_certificate(sys: Mjls, digits: int = 12) -> bool:
    """The cheap certificate: float ``Y = T(Y) + I`` rounded to rationals, ``Y > 0`` and ``Y - T(Y) > 0`` exactly."""
    Tf = float_operator(sys)
    s = len(vech_index(sys.d))
    rhs = np.tile([1.0 if a == b else 0.0 for a, b in vech_index(sys.d)], sys.modes)
    try:
        y = np.linalg.solve(np.eye(Tf.shape[0]) - Tf, rhs)
    except np.linalg.LinAlgError:
        return False
    scale = 10**digits
    Y = []
    for j in range(sys.modes):
        v = [flint.fmpq(int(round(float(x) * scale)), scale) for x in y[j * s : (j + 1) * s]]
        Y.append(unvech(v, sys.d))
    if not all(positive_definite(X) for X in Y):
        return False
    TY = apply_exact(sys, Y)
    return all(positive_definite(X - TX) for X, TX in zip(Y, TY))


def _tick(budget: Budget | None, what: str) -> None:
    if budget is not None:
        budget.tick(what)


def data_bits(sys: Mjls) -> int:
    """The largest bit length of a numerator or denominator in the loop's maps and transition law."""
    bits = 0
    for branches in sys.branches:
        for br in branches:
            for i in range(br.M.nrows()):
                for j in range(br.M.ncols()):
                    x = br.M[i, j]
                    bits = max(bits, int(x.p).bit_length(), int(x.q).bit_length())
            bits = max(bits, br.weight.numerator.bit_length(), br.weight.denominator.bit_length())
    for row in sys.P:
        for p in row:
            bits = max(bits, p.numerator.bit_length(), p.denominator.bit_length())
    return bits


def exact_route(sys: Mjls) -> bool:
    """Whether the exact route is fast for this system: small, or short data (:data:`EXACT_ROUTE_SIZE`)."""
    size = sys.modes * len(vech_index(sys.d))
    return size <= EXACT_ROUTE_SIZE or (size <= MAX_EXACT_SIZE and data_bits(sys) <= SHORT_DATA_BITS)


def decide(sys: Mjls, budget: Budget | None = None, *, route: str = "auto") -> Decision:
    """The verdict (see the module docstring) and the stationary second moments when decided exactly.

    ``route`` is ``"auto"`` (:func:`exact_route` chooses), ``"exact"`` or ``"certified"`` (the float
    certificates of :mod:`kfio.loop._certify`, the exact route only when they cannot decide).
    ``budget`` (:class:`kfio.Budget`) is checked between the steps of the exact work (operator,
    solve, characteristic polynomial); :class:`kfio.errors.BudgetExceeded` when it is spent.
    """
    if route == "certified" or (route == "auto" and not exact_route(sys)):
        _tick(budget, "loop verdict: verified float certificate")
        cert = certify(sys)
        size = sys.modes * len(vech_index(sys.d))
        if cert.verdict is not None:
            return Decision(
                cert.verdict,
                False,
                True,
                cert.certificate,
                cert.radius,
                None,
                size,
                None,
                cert.radius_enclosure,
                cert.cost,
                cert.cost_enclosure,
            )
        if size > MAX_EXACT_SIZE:
            verdict = "unstable" if cert.radius >= 1 else "stable"
            return Decision(verdict, False, False, "none", cert.radius, None, size, None, cert.radius_enclosure)
    _tick(budget, "loop verdict: float operator")
    Tf = float_operator(sys)
    size = Tf.shape[0]
    rho = float(np.max(np.abs(np.linalg.eigvals(Tf)))) if size else 0.0
    _tick(budget, "loop verdict: exact operator")
    T = operator_matrix(sys)
    _tick(budget, "loop verdict: exact Lyapunov solve")
    identity = flint.fmpq_mat(size, size)
    for i in range(size):
        identity[i, i] = 1
    rhs = flint.fmpq_mat(size, 2)
    s = len(vech_index(sys.d))
    for j in range(sys.modes):
        for r, (a, b) in enumerate(vech_index(sys.d)):
            rhs[j * s + r, 0] = 1 if a == b else 0
    noise = noise_vector(sys)
    for i in range(size):
        rhs[i, 1] = noise[i, 0]
    rho_text = None
    try:
        sol = (identity - T).solve(rhs, algorithm="dixon")  # type: ignore[call-arg]
    except ZeroDivisionError:
        _tick(budget, "loop verdict: characteristic polynomial")
        sign, rho_text = exact_radius(sys, T)
        verdict = "boundary" if sign == 0 else ("unstable" if sign > 0 else "stable")
        if sign < 0:  # cannot happen: 1 is an eigenvalue, so rho >= 1
            raise NumericalFailure("I - T is singular but no eigenvalue >= 1 was found") from None
        return Decision(verdict, True, True, "characteristic polynomial", rho, rho_text, size, None)
    _tick(budget, "loop verdict: definiteness of the Lyapunov solution")
    Y = _stacked(sys, sol, 0)
    stable = all(positive_definite(X) for X in Y)
    if size <= MAX_EXACT_RADIUS_SIZE:
        _, rho_text = exact_radius(sys, T)
    if stable:
        moments = tuple(_stacked(sys, sol, 1))
        return Decision("stable", True, True, "exact Lyapunov solution", rho, rho_text, size, moments)
    return Decision(
        "unstable", True, True, "I - T invertible, Lyapunov solution not definite", rho, rho_text, size, None
    )


__all__ = [
    "Decision",
    "data_bits",
    "decide",
    "exact_radius",
    "exact_route",
    "positive_definite",
    "rounded_certificate",
    "vech",
]
