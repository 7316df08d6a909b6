"""LAPACK's answers on tiny matrices without NumPy's per-call checks (the slide's inner loop).

``numpy.linalg.solve`` and ``numpy.linalg.cholesky`` spend most of their time on a 3 x 3 or
6 x 6 matrix checking shapes and types and entering an error state.  The slide of
:meth:`kfio.riccati_bounds._search.CertifiedSearch._slide` asks thousands of times whether
``Y - L_K(Y) = I`` has a positive definite solution, on float64 matrices it built itself, so it
calls the same LAPACK kernels (NumPy's ``_umath_linalg`` gufuncs, the ones those functions call)
directly: the same floats, the same decisions.  A failed factorization fills its output with
NaN, which is how failure is read here.  Where the private module is missing, the public
functions are used.

:func:`cholesky` and :func:`solve` serve the batched gain of ``P_hat_N`` with two or more outputs
(:class:`kfio.riccati_bounds._phat.BatchedMare`): NumPy's answer on every input, the kernel's
floats where it succeeds, and the public function itself (its floats or its ``LinAlgError``)
wherever a NaN shows up.  They skip the ``errstate`` context of the functions above (a third of
a call's cost): a failing kernel raises the invalid-value flag, so outside an ``errstate`` that
ignores it a ``RuntimeWarning`` comes before the public function's ``LinAlgError``.  ``P_hat_N``
iterates inside such a context.
"""

from __future__ import annotations

import numpy as np

try:  # the kernels behind numpy.linalg.solve and numpy.linalg.cholesky
    from numpy.linalg import _umath_linalg as _kernels

    _solve1 = _kernels.solve1
    _solve = _kernels.solve
    _cholesky_lo = _kernels.cholesky_lo
    _DIRECT = True
except (ImportError, AttributeError):  # pragma: no cover - another NumPy layout
    _DIRECT = False


def solve_finite(L: np.ndarray, rhs: np.ndarray) -> np.ndarray | None:
    """``y = L^-1 rhs`` for a float64 matrix ``L`` and vector ``rhs``, if finite.

    Returns ``np.linalg.solve(L, rhs)`` (the same floats: LAPACK ``gesv`` through the same gufunc),
    or ``None`` where that raises ``LinAlgError`` or gives a non-finite entry.
    """
    if not _DIRECT:  # pragma: no cover
        try:
            y = np.linalg.solve(L, rhs)
        except np.linalg.LinAlgError:
            return None
        return y if np.all(np.isfinite(y)) else None
    with np.errstate(all="ignore"):
        y = _solve1(L, rhs, signature="dd->d")
    return y if np.isfinite(y).all() else None


def cholesky_succeeds(M: np.ndarray) -> bool:
    """Whether ``np.linalg.cholesky(M)`` succeeds on a finite float64 matrix (LAPACK ``potrf``).

    On failure NumPy's kernel fills the factor with NaN (and ``numpy.linalg.cholesky`` raises);
    on a finite ``M`` a successful factor is finite, so "no NaN" is "no exception".
    """
    if not _DIRECT:  # pragma: no cover
        try:
            np.linalg.cholesky(M)
        except np.linalg.LinAlgError:
            return False
        return True
    with np.errstate(all="ignore"):
        F = _cholesky_lo(M, signature="d->d")
    return not np.isnan(F).any()


def cholesky(M: np.ndarray) -> np.ndarray:
    """``numpy.linalg.cholesky(M)`` for a float64 stack ``M`` (``... x p x p``), the same floats and errors.

    The kernel's factor where it holds no NaN (a failed factorization is all NaN, and a successful
    one of a matrix without NaN has none: each entry below the diagonal enters a later pivot);
    otherwise the public function decides, raising ``LinAlgError`` as it does.
    """
    if _DIRECT:
        F = _cholesky_lo(M, signature="d->d")
        if not np.isnan(F).any():
            return np.asarray(F)
    return np.linalg.cholesky(M)


def solve(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``numpy.linalg.solve(a, b)`` for float64 stacks ``a`` (``... x p x p``) and ``b`` (``... x p x k``): same floats and errors.

    The kernel's answer (LAPACK ``gesv``, the gufunc NumPy calls for a matrix right-hand side) where
    it holds no NaN; otherwise the public function's answer or its ``LinAlgError``.
    """
    if _DIRECT:
        y = _solve(a, b, signature="dd->d")
        if not np.isnan(y).any():
            return np.asarray(y)
    return np.linalg.solve(a, b)
