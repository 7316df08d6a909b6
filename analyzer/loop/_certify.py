"""The loop's verdict proved with floating point and interval arithmetic: any size, at float speed.

``T(Y)_j = sum_i p_ij sum_b w_b M_b Y_i M_b'`` is a positive map on ``N``
symmetric matrices (:mod:`kfio.loop._operator`); ``X >= Y`` below is the
Loewner order mode by mode.  Three facts of positive maps (Costa, Fragoso and
Marques 2005, Ch. 3 and Thm 3.9) turn float candidates into proofs:

* **stable**: if some ``Y`` has every ``Y_i > 0`` and every ``R_i > 0``,
  ``R = Y - T(Y)``, then ``rho(T) < 1`` (Thm 3.9);
* **unstable**: if some ``Z`` has every ``Z_i > 0`` and ``T(Z) - r Z >= 0``
  with ``r > 1``, then ``rho(T) >= r > 1``: ``T^k(Z) >= r^k Z`` and, were
  ``rho < r``, ``T^k(Z) / r^k -> 0`` would force ``Z <= 0``.  Perron
  eigen-matrices of real loops are often singular to rounding, so the first
  proof tried is another one (:func:`verify_indefinite`): were ``rho(T / s) < 1``,
  the solution of ``Y - T(Y) / s = I`` would be ``>= I``, and a float solution
  with a small enclosed residual that has a direction ``x' Y_i x < (1 - e) x' x``
  proves ``rho(T) >= s`` (``s = 1 + 2^-40``);
* **enclosure of rho** (Collatz-Wielandt): ``T(Z) >= r Z`` with ``Z > 0`` gives
  ``rho >= r``; ``T(Y) <= s Y`` with ``Y > 0`` gives ``rho <= s`` (every ``X`` is
  below ``c Y`` for some ``c``, so ``T^k(X) <= c s^k Y``).  With ``Y = I``:
  ``rho <= max_j lambda_max(T(I)_j)``; with the Lyapunov ``Y``:
  ``T(Y) = Y - R <= (1 - c / max_i lambda_max(Y_i)) Y`` when ``R_i >= c I``.

The candidates are floats (numpy: the coupled Lyapunov equation
``Y - T(Y) = I`` and, for instability, the Perron eigen-matrix of ``T``); the
proofs are not.  ``R``, ``T(Z) - r Z`` and every other matrix checked are
enclosed entrywise in Arb balls (python-flint ``arb_mat``, the loop's exact
rational data rounded outward), and a symmetric interval matrix ``A`` is
proved positive definite by congruence: for any float ``V`` (the eigenvectors
of ``A``'s midpoint), if ``V' A V`` (balls) is strictly diagonally dominant
with a positive diagonal for every matrix in the enclosure, then ``V' A V > 0``
(Gershgorin), so ``V`` is invertible and ``A > 0`` (Sylvester's law of
inertia).  This is a verified eigenvalue enclosure in the sense of Rump 2006
("Verification of positive definiteness", BIT 46): no rounding error of the
float eigensolver can make it accept a matrix that is not definite.

**Stationary cost.**  The moments solve ``X - T(X) = N`` (``N`` the noise
forcing).  For the float solution ``X_hat`` the residual
``E = X_hat - T(X_hat) - N`` is enclosed in balls; if ``R_i >= c I`` then
``-e R <= E <= e R`` with ``e = max_i ||E_i||_F / c``.  ``(I - T)^-1 = sum_k T^k``
is a positive map with ``(I - T)^-1 (R) = Y``, so ``X - X_hat = -(I - T)^-1 (E)``
lies between ``-e Y`` and ``e Y``.  The cost is ``J(X) = l(X) + const`` with
``l(X) = sum_i tr(H_i X_i)``, ``H_i >= 0`` (``W`` and ``U`` are positive
semidefinite), so ``|J(X) - J(X_hat)| <= e l(Y)``: a certified enclosure whose
width is the float solve's residual measured by the certificate's own margin.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Callable, Sequence

import flint
import numpy as np

from ._mjls import Mjls
from ._operator import float_operator, noise_vector, to_numpy, vech_index

#: Relative steps around the float ``rho`` at which the Perron candidates are tried.
TAUS = (1e-9, 1e-6, 1e-3, 1e-2, 1e-1)
#: Largest operator size whose upper bound of ``rho`` is tightened by extra resolvent solves (one dense solve each).
RESOLVENT_SIZE = 3000

#: Bits of the Arb balls of the cost enclosure: the data rounded at 53 bits would make the enclosure's
#: width that rounding times ``||X|| l(Y)``, far above the refined float solution's own error.
COST_PRECISION = 120

#: Operator sizes up to this use numpy's dense eigenvalues for the float radius; above, ARPACK.
DENSE_EIGEN_SIZE = 300

STABLE_CERTIFICATE = "verified float Lyapunov certificate (interval arithmetic, Rump 2006)"
INDEFINITE_CERTIFICATE = (
    "verified float Lyapunov solution not positive definite: rho(T) > 1 (interval arithmetic, Rump 2006)"
)
#: ``rho(T) >= 1 + 2^-40`` is what the indefinite-solution certificate proves (the float solve of ``T`` reused).
INDEFINITE_SCALE = 1 + Fraction(1, 2**40)
UNSTABLE_CERTIFICATE = "verified float Perron certificate T(Z) >= r Z, r > 1 (interval arithmetic, Rump 2006)"


@dataclass(frozen=True)
class Certified:
    """What the float route proved: ``verdict`` is ``None`` when neither certificate verified.

    ``radius_enclosure`` and ``cost_enclosure`` are proved bounds ``(lo, hi)`` as exact
    Fractions (ends of Arb balls); ``cost`` is the float cost of the float moments.
    """

    verdict: str | None
    certificate: str
    radius: float
    radius_enclosure: tuple[Fraction, Fraction] | None
    cost: float | None
    cost_enclosure: tuple[Fraction, Fraction] | None


def _arb(x: Fraction | flint.fmpq) -> flint.arb:
    if isinstance(x, Fraction):
        x = flint.fmpq(x.numerator, x.denominator)
    return flint.arb(x)


def _exact(x: flint.arb) -> Fraction:
    """The value of an exact ball (an endpoint of a ball), as a Fraction."""
    man, exp = (int(v) for v in x.man_exp())
    return Fraction(man) * Fraction(2) ** exp


class _Balls:
    """The loop's exact data as Arb balls, built once per system: mode maps, weights, cost terms."""

    def __init__(self, sys: Mjls) -> None:
        self.sys = sys
        cache: dict[int, flint.arb_mat] = {}
        self.branches: list[list[tuple[flint.arb, flint.arb_mat, flint.arb_mat]]] = []
        for branches in sys.branches:
            row = []
            for br in branches:
                if id(br.M) not in cache:
                    cache[id(br.M)] = flint.arb_mat(br.M)
                M = cache[id(br.M)]
                row.append((_arb(br.weight), M, M.transpose()))
            self.branches.append(row)
        self.P = [[_arb(p) if p else None for p in row] for row in sys.P]

    def apply(self, Y: Sequence[flint.arb_mat], adjoint: bool = False) -> list[flint.arb_mat]:
        """``T(Y)`` (or the adjoint ``T*(Y)_i = sum_j p_ij sum_b w_b M_b' Y_j M_b``) enclosed in balls."""
        sys = self.sys
        if adjoint:
            outs = []
            for i, row in enumerate(self.branches):
                mix = flint.arb_mat(sys.d, sys.d)
                for j in range(sys.modes):
                    p = self.P[i][j]
                    if p is not None:
                        mix += p * Y[j]
                img = flint.arb_mat(sys.d, sys.d)
                for w, M, Mt in row:
                    img += w * (Mt * mix * M)
                outs.append(img)
            return outs
        imgs = []
        for i, row in enumerate(self.branches):
            img = flint.arb_mat(sys.d, sys.d)
            for w, M, Mt in row:
                img += w * (M * Y[i] * Mt)
            imgs.append(img)
        out = []
        for j in range(sys.modes):
            acc = flint.arb_mat(sys.d, sys.d)
            for i in range(sys.modes):
                p = self.P[i][j]
                if p is not None:
                    acc += p * imgs[i]
            out.append(acc)
        return out


def _mid(A: flint.arb_mat) -> np.ndarray:
    d = A.nrows()
    return np.array([[float(A[i, j].mid()) for j in range(d)] for i in range(d)]).reshape(d, d)


def definite(A: flint.arb_mat) -> bool:
    """Every symmetric matrix inside the balls of ``A`` is positive definite, proved (module docstring).

    ``V`` is the float eigenvector matrix of ``A``'s symmetrized midpoint; ``B = V' A V`` is enclosed in
    balls and checked row by row: ``B_ii - sum_{j != i} |B_ij| > 0`` with certainty.
    """
    d = A.nrows()
    if d == 0:
        return True
    mid = _mid(A)
    if not np.all(np.isfinite(mid)):
        return False
    _, vecs = np.linalg.eigh((mid + mid.T) / 2)
    V = flint.arb_mat(vecs.tolist())
    B = V.transpose() * A * V
    zero = flint.arb(0)
    for i in range(d):
        s = B[i, i]
        for j in range(d):
            if j != i:
                s -= abs(B[i, j])
        if not s > zero:
            return False
    return True


def _sym(v: np.ndarray, d: int) -> np.ndarray:
    X = np.zeros((d, d))
    for r, (a, b) in enumerate(vech_index(d)):
        X[a, b] = X[b, a] = v[r]
    return X


def _stack(sys: Mjls, y: np.ndarray) -> list[np.ndarray]:
    s = len(vech_index(sys.d))
    return [_sym(y[j * s : (j + 1) * s], sys.d) for j in range(sys.modes)]


def _balls(Xs: Sequence[np.ndarray]) -> list[flint.arb_mat]:
    return [flint.arb_mat(np.asarray(X, dtype=float).tolist()) if X.size else flint.arb_mat(0, 0) for X in Xs]


def _eye(d: int, c: flint.arb | int = 1) -> flint.arb_mat:
    out = flint.arb_mat(d, d)
    for i in range(d):
        out[i, i] = c
    return out


def _frobenius_upper(A: flint.arb_mat) -> flint.arb:
    """An exact upper bound of ``||A||_F`` over every matrix in the balls."""
    d = A.nrows()
    s = flint.arb(0)
    for i in range(d):
        for j in range(d):
            u = A[i, j].abs_upper()
            s += u * u
    return s.sqrt().upper()


def verify_stable(balls: _Balls, Y: Sequence[np.ndarray], scale: Fraction = Fraction(1)) -> flint.arb | None:
    """``c > 0`` with ``Y_i > 0`` and ``Y_i - T(Y)_i >= c I`` proved for every mode (so ``rho(T) < 1``), else ``None``.

    ``Y`` is any float candidate; a wrong one is rejected, never accepted.  With ``scale = t`` the map
    is ``T / t`` (so ``rho(T) < t``).
    """
    d = balls.sys.d
    Yb = _balls(Y)
    if not all(definite(X) for X in Yb):
        return None
    inv = _arb(1 / scale)
    R = [X - inv * TX for X, TX in zip(Yb, balls.apply(Yb))]
    lams = [float(np.linalg.eigvalsh((m + m.T) / 2)[0]) if d else 1.0 for m in map(_mid, R)]
    lo = min(lams)
    if not lo > 0:
        return None
    c = flint.arb(flint.fmpq(Fraction(lo / 2).numerator, Fraction(lo / 2).denominator))
    if not all(definite(Ri - _eye(d, c)) for Ri in R):
        return None
    return c


def verify_indefinite(balls: _Balls, Y: Sequence[np.ndarray], s: Fraction) -> bool:
    """``rho(T) >= s`` proved from a float solution ``Y`` of ``Y - T(Y) / s = I`` that is not positive definite.

    Were ``rho(T / s) < 1``, the exact solution ``Y* = sum_k (T / s)^k (I)`` would be ``>= I`` and
    ``(I - T / s)^-1`` a positive map.  With ``E = Y - T(Y) / s - I`` enclosed and ``-e I <= E <= e I``
    (``e >= max_i ||E_i||_F``), ``Y = Y* + (I - T / s)^-1 (E) >= (1 - e) Y* >= (1 - e) I``.  So ``e < 1`` and
    one ``x' Y_i x < (1 - e) x' x`` (checked in balls, ``x`` the float eigenvector of ``Y_i``'s least
    eigenvalue) prove ``rho(T / s) >= 1``.
    """
    d = balls.sys.d
    if not Y or not d:
        return False
    Yb = _balls(Y)
    inv = _arb(1 / s)
    E = [X - inv * TX - _eye(d) for X, TX in zip(Yb, balls.apply(Yb))]
    e = flint.arb(0)
    for Ei in E:
        e = e.max(_frobenius_upper(Ei))
    if not e < 1:
        return False
    for X, Xb in zip(Y, Yb):
        _, vecs = np.linalg.eigh((X + X.T) / 2)
        x = flint.arb_mat([[float(v)] for v in vecs[:, 0]])
        q = (x.transpose() * Xb * x)[0, 0] - (1 - e) * (x.transpose() * x)[0, 0]
        if q < 0:
            return True
    return False


def verify_growth(balls: _Balls, Z: Sequence[np.ndarray], r: Fraction, adjoint: bool = False) -> bool:
    """``Z_i > 0`` and ``T(Z)_i - r Z_i > 0`` proved for every mode: ``rho(T) >= r`` (module docstring).

    With ``adjoint`` the same for ``T*``, whose spectral radius is that of ``T``.
    """
    Zb = _balls(Z)
    if not all(definite(X) for X in Zb):
        return False
    rb = _arb(r)
    return all(definite(TX - rb * X) for X, TX in zip(Zb, balls.apply(Zb, adjoint)))


def verify_decay(balls: _Balls, Z: Sequence[np.ndarray], s: Fraction, adjoint: bool = False) -> bool:
    """``Z_i > 0`` and ``s Z_i - T(Z)_i > 0`` proved for every mode: ``rho(T) <= s`` (Collatz-Wielandt)."""
    Zb = _balls(Z)
    if not all(definite(X) for X in Zb):
        return False
    sb = _arb(s)
    return all(definite(sb * X - TX) for X, TX in zip(Zb, balls.apply(Zb, adjoint)))


class _Floats:
    """The mode maps in float64, for the matrix-free ``T`` and ``T*`` on stacked ``vech`` vectors."""

    def __init__(self, sys: Mjls) -> None:
        self.sys = sys
        self.d = sys.d
        idx = vech_index(sys.d)
        self.rows = np.array([a for a, _ in idx], dtype=int)
        self.cols = np.array([b for _, b in idx], dtype=int)
        self.s = len(idx)
        self.P = np.array([[float(p) for p in row] for row in sys.P]).reshape(sys.modes, sys.modes)
        self.branches = [[(float(br.weight), to_numpy(br.M)) for br in row] for row in sys.branches]

    def mats(self, y: np.ndarray) -> np.ndarray:
        X = np.zeros((self.sys.modes, self.d, self.d))
        Y = y.reshape(self.sys.modes, self.s)
        X[:, self.rows, self.cols] = Y
        X[:, self.cols, self.rows] = Y
        return X

    def vec(self, X: np.ndarray) -> np.ndarray:
        return np.asarray(X[:, self.rows, self.cols].reshape(-1))

    def apply(self, y: np.ndarray, adjoint: bool = False) -> np.ndarray:
        X = self.mats(y)
        if adjoint:
            mix = np.einsum("ij,jab->iab", self.P, X)
            out = np.stack(
                [
                    sum((w * (M.T @ mix[i] @ M) for w, M in row), np.zeros((self.d, self.d)))
                    for i, row in enumerate(self.branches)
                ]
            )
        else:
            img = np.stack(
                [
                    sum((w * (M @ X[i] @ M.T) for w, M in row), np.zeros((self.d, self.d)))
                    for i, row in enumerate(self.branches)
                ]
            )
            out = np.einsum("ij,iab->jab", self.P, img)
        return self.vec(out)


def _perron(fl: _Floats, adjoint: bool) -> tuple[float, np.ndarray | None]:
    """The float spectral radius of ``T`` (or ``T*``) and an eigenvector of its eigenvalue of largest real part.

    ``rho(T)`` is itself an eigenvalue (a positive map), and it has the largest real part of all:
    every eigenvalue has ``Re <= |.| <= rho``.
    """
    size = fl.sys.modes * fl.s
    if size == 0:
        return 0.0, None
    if size <= DENSE_EIGEN_SIZE:
        basis = np.eye(size)
        T = np.column_stack([fl.apply(basis[:, k], adjoint) for k in range(size)])
        vals, vecs = np.linalg.eig(T)
        k = int(np.argmax(vals.real))
        return float(np.max(np.abs(vals))), np.real(vecs[:, k])
    from scipy.sparse.linalg import ArpackNoConvergence, LinearOperator, eigs

    op = LinearOperator((size, size), matvec=lambda y: fl.apply(np.asarray(y).reshape(-1), adjoint), dtype=float)
    try:
        vals, vecs = eigs(op, k=4, which="LM", tol=1e-13, ncv=min(size - 1, 40), maxiter=300)
    except ArpackNoConvergence as exc:  # clustered dominant eigenvalues: keep what converged, if anything
        vals, vecs = exc.eigenvalues, exc.eigenvectors
        if len(vals) == 0:
            return float("nan"), None
    k = int(np.argmax(vals.real))
    return float(np.max(np.abs(vals))), np.real(vecs[:, k])


def _fraction(x: float) -> Fraction:
    return Fraction(x)


def _upper_from_identity(balls: _Balls) -> Fraction:
    """``max_j ||T(I)_j||_F``, an upper bound of ``rho(T)`` (``T(I) <= c I``, Collatz-Wielandt with ``Y = I``)."""
    d = balls.sys.d
    imgs = balls.apply([_eye(d) for _ in range(balls.sys.modes)])
    return max((_exact(_frobenius_upper(X).upper()) for X in imgs), default=Fraction(0))


def _whitened(balls: _Balls, Z: Sequence[np.ndarray], adjoint: bool) -> tuple[_Balls, list[np.ndarray]] | None:
    """The same operator after the congruence ``X -> S X S'`` that turns ``sum_i Z_i`` into about ``I``.

    ``S M_b S^-1`` replaces every ``M_b`` (``S^-1`` enclosed by Arb), which maps the cone onto itself and
    keeps ``rho``; a Perron candidate with eigenvalues from ``1e-12`` to ``1`` (a nearly invariant
    subspace) becomes one of eigenvalues near 1, whose certificate no longer drowns in rounding.
    For ``T*`` the congruence is ``X -> S^-T X S^-1``, with the same ``S M_b S^-1``.
    """
    total = sum(Z, np.zeros_like(Z[0]))
    lam, V = np.linalg.eigh((total + total.T) / 2)
    if not lam[0] > 0:
        return None
    S = (np.diag(lam**0.5) if adjoint else np.diag(lam**-0.5)) @ V.T
    Sb = flint.arb_mat(S.tolist())
    try:
        Sinv = Sb.inv()
    except ZeroDivisionError:
        return None
    out = object.__new__(_Balls)
    out.sys = balls.sys
    out.P = balls.P
    out.branches = []
    for row in balls.branches:
        new = []
        for w, M, _ in row:
            Mt = Sb * M * Sinv
            new.append((w, Mt, Mt.transpose()))
        out.branches.append(new)
    Si = np.linalg.inv(S)
    cand = [Si.T @ X @ Si for X in Z] if adjoint else [S @ X @ S.T for X in Z]
    return out, [(X + X.T) / 2 for X in cand]


def _radius_bounds(
    balls: _Balls,
    rho: float,
    cands: Sequence[tuple[list[np.ndarray], bool]],
    floor: Fraction,
    ceil: Fraction,
    upper: bool = False,
) -> tuple[Fraction, Fraction]:
    """Tighten ``[floor, ceil]`` around ``rho`` with Perron candidates of ``T`` or ``T*`` (each side proved).

    The lower end always; the upper end only with ``upper`` (else the resolvent, :func:`_resolvent_upper`).
    """
    lo, hi = floor, ceil
    for Z, adjoint in cands:
        tries = [(balls, Z)]
        w = _whitened(balls, Z, adjoint)
        if w is not None:
            tries.append(w)
        for b, X in tries:
            for tau in TAUS:
                r = _fraction(rho * (1 - tau))
                if r <= lo:
                    break
                if verify_growth(b, X, r, adjoint):
                    lo = r
                    break
            for tau in TAUS if upper else ():
                t = _fraction(rho * (1 + tau))
                if t >= hi:
                    break
                if verify_decay(b, X, t, adjoint):
                    hi = t
                    break
        if lo > floor:
            break
    return lo, hi


def _resolvent_upper(balls: _Balls, Tf: np.ndarray, fl: _Floats, rho: float, hi: Fraction) -> Fraction:
    """A smaller proved upper bound of ``rho``: ``Y - T(Y) / t = I`` with a verified solution gives ``rho(T / t) < 1``.

    ``Y = sum_k (T / t)^k (I) >= I`` when ``rho < t``, so the candidate is well inside the cone and the proof
    (:func:`verify_stable` on the scaled map) rarely fails; each try costs one dense solve.
    """
    size = Tf.shape[0]
    ident = np.tile([1.0 if a == b else 0.0 for a, b in vech_index(fl.d)], fl.sys.modes)
    for frac in (1e-3, 1e-2, 1e-1, 0.5):
        t = _fraction(rho + frac * (float(hi) - rho))
        if not rho < t < hi:
            continue
        try:
            y = np.linalg.solve(np.eye(size) - Tf / float(t), ident)
        except np.linalg.LinAlgError:
            continue
        if np.all(np.isfinite(y)) and verify_stable(balls, list(fl.mats(y)), t) is not None:
            return t
    return hi


def _resolvent_lower(balls: _Balls, Tf: np.ndarray, fl: _Floats, rho: float, lo: Fraction) -> Fraction:
    """A larger proved lower bound of ``rho``: a solution of ``Y - T(Y) / t = I`` that is not ``>= I``.

    :func:`verify_indefinite` on ``T / t`` for ``t`` just below the float ``rho``; each try costs one dense solve.
    """
    size = Tf.shape[0]
    ident = np.tile([1.0 if a == b else 0.0 for a, b in vech_index(fl.d)], fl.sys.modes)
    for tau in (1e-6, 1e-3, 1e-2):
        t = _fraction(rho * (1 - tau))
        if t <= lo:
            break
        try:
            y = np.linalg.solve(np.eye(size) - Tf / float(t), ident)
        except np.linalg.LinAlgError:
            continue
        if np.all(np.isfinite(y)) and verify_indefinite(balls, list(fl.mats(y)), t):
            return t
    return lo


def _perron_matrices(fl: _Floats, v: np.ndarray | None) -> list[np.ndarray] | None:
    """The eigenvector as mode matrices, signed to a positive trace and scaled to entries of order 1."""
    if v is None or not np.all(np.isfinite(v)):
        return None
    Z = list(fl.mats(v))
    if sum(float(np.trace(X)) for X in Z) < 0:
        Z = [-X for X in Z]
    scale = max(float(np.max(np.abs(X))) for X in Z) if Z else 0.0
    if not scale > 0:
        return None
    return [X / scale for X in Z]


def _candidates(
    fl: _Floats, sides: tuple[bool, ...] = (False, True)
) -> tuple[float, list[tuple[list[np.ndarray], bool]]]:
    """The float ``rho`` and the Perron eigen-matrices of ``T`` and of ``T*`` that are positive definite in floats.

    One of the two is often singular: in the coordinates ``(x, x - x_hat)`` of a TCP-like loop the
    maps are block triangular, so the dominant eigen-matrix of one side lives on an invariant subspace.
    """
    out = []
    rhos = []
    for adjoint in sides:
        rho, v = _perron(fl, adjoint)
        rhos.append(rho)
        Z = _perron_matrices(fl, v)
        if Z is None or not Z[0].size:
            continue
        low = min(float(np.linalg.eigvalsh(X)[0]) for X in Z)
        if low > -1e-8:  # rounding of a singular eigen-matrix: lift it into the interior (entries are <= 1)
            shift = max(0.0, -2 * low) + 1e-12
            out.append(([X + shift * np.eye(X.shape[0]) for X in Z], adjoint))
    finite = [r for r in rhos if np.isfinite(r)]
    return (finite[0] if finite else float("nan")), out


def _cost_balls(balls: _Balls, X: Sequence[flint.arb_mat]) -> tuple[flint.arb, flint.arb]:
    """``(l(X), const)``: the linear part ``sum_i tr(H_i X_i)`` and the noise part of the cost (module docstring)."""
    sys = balls.sys
    Wz = flint.arb_mat(sys.Wz)
    U = flint.arb_mat(sys.U) if sys.U.nrows() else None
    lin = flint.arb(0)
    const = flint.arb(0)
    for i, (Xi, branches) in enumerate(zip(X, sys.branches)):
        lin += (Wz * Xi).trace()
        if U is None:
            continue
        pi = _arb(sys.pi[i])
        for br in branches:
            w = _arb(br.weight)
            F = flint.arb_mat(br.Fa)
            lin += w * (U * F * Xi * F.transpose()).trace()
            E = flint.arb_mat(br.Ea)
            const += w * pi * (U * E * flint.arb_mat(sys.Sigma) * E.transpose()).trace()
    return lin, const


def _noise_balls(sys: Mjls, noise: flint.fmpq_mat) -> list[flint.arb_mat]:
    s = len(vech_index(sys.d))
    out = []
    for j in range(sys.modes):
        Nj = flint.arb_mat(sys.d, sys.d)
        for r, (a, b) in enumerate(vech_index(sys.d)):
            Nj[a, b] = Nj[b, a] = flint.arb(noise[j * s + r, 0])
        out.append(Nj)
    return out


def _cost_enclosure(
    balls: _Balls,
    Y: list[np.ndarray],
    c: flint.arb,
    X: list[np.ndarray],
    noise: flint.fmpq_mat,
    refine: Callable[[np.ndarray], np.ndarray] | None = None,
) -> tuple[float, tuple[Fraction, Fraction]]:
    """The float cost of ``X`` and its proved enclosure ``J(X_hat) +- e l(Y)`` (module docstring)."""
    Yb, Xb = _balls(Y), _balls(X)
    N = _noise_balls(balls.sys, noise)
    E = [Xi - TX - Nj for Xi, TX, Nj in zip(Xb, balls.apply(Xb), N)]
    if refine is not None:
        # one step of iterative refinement: the residual is exact to the last bit, so the corrected
        # X_hat's residual (and the enclosure's width) shrinks by about the float solve's accuracy
        fl = _Floats(balls.sys)
        dx = refine(fl.vec(np.stack([_mid(Ei) for Ei in E])))
        if np.all(np.isfinite(dx)):
            X = [Xi - Di for Xi, Di in zip(X, fl.mats(dx))]
            Xb = _balls(X)
            E = [Xi - TX - Nj for Xi, TX, Nj in zip(Xb, balls.apply(Xb), N)]
    e = flint.arb(0)
    for Ei in E:
        e = e.max(_frobenius_upper(Ei) / c)
    lin_x, const = _cost_balls(balls, Xb)
    lin_y, _ = _cost_balls(balls, Yb)
    ball = lin_x + const
    width = e.upper() * lin_y.upper()
    lo, hi = (ball.lower() - width).lower(), (ball.upper() + width).upper()
    return float(ball.mid()), (max(_exact(lo), Fraction(0)), _exact(hi))


def certify(sys: Mjls, *, enclose: bool = True) -> Certified:
    """The verdict of ``rho(T)`` against 1 proved from float candidates, with enclosures (module docstring).

    ``verdict`` is ``None`` when neither certificate verifies: near ``rho = 1`` only exact arithmetic
    decides.  ``enclose=False`` proves the verdict only (the bisection of critical values): the
    enclosures are then ``None`` and ``radius`` is ``nan`` unless the Perron candidates were needed.
    """
    fl = _Floats(sys)
    size = sys.modes * fl.s
    balls = _Balls(sys)
    noise = noise_vector(sys)
    Tf = float_operator(sys)
    ident = np.tile([1.0 if a == b else 0.0 for a, b in vech_index(sys.d)], sys.modes)
    nvec = np.array([float(noise[i, 0]) for i in range(size)])
    lu = None
    try:
        if size:
            from scipy.linalg import lu_factor, lu_solve

            lu = lu_factor(np.eye(size) - Tf, check_finite=False)
            sol = lu_solve(lu, np.column_stack([ident, nvec]), check_finite=False)
        else:
            sol = np.zeros((0, 2))
    except (np.linalg.LinAlgError, ValueError):
        sol = None
    c = None
    if sol is not None and np.all(np.isfinite(sol)):
        Y = list(fl.mats(sol[:, 0]))
        c = verify_stable(balls, Y)
    if c is not None and sol is not None:
        if not enclose:
            return Certified("stable", STABLE_CERTIFICATE, float("nan"), None, None, None)
        rho, cands = _candidates(fl, (False,))
        # rho <= 1 - c / max ||Y_i||: T(Y) = Y - R <= Y - c I and I >= Y / ||Y_i||
        norms = [_frobenius_upper(X) for X in _balls(Y)]
        ymax = max(norms, key=float) if norms else flint.arb(1)
        lyap = _exact((1 - c / ymax).upper()) if ymax > 0 else Fraction(1)
        ceil = min(_upper_from_identity(balls), lyap)
        lo, hi = _radius_bounds(balls, rho, cands, Fraction(0), ceil, upper=size > RESOLVENT_SIZE)
        if lo == 0:
            lo, hi = _radius_bounds(balls, rho, _candidates(fl, (True,))[1], lo, hi, upper=size > RESOLVENT_SIZE)
        if size <= RESOLVENT_SIZE and np.isfinite(rho) and hi > _fraction(rho) * (1 + Fraction(1, 10**9)):
            hi = _resolvent_upper(balls, Tf, fl, rho, hi)
        if size <= RESOLVENT_SIZE and np.isfinite(rho) and rho > 0 and lo < _fraction(rho) * Fraction(99, 100):
            lo = _resolvent_lower(balls, Tf, fl, rho, lo)
        refine = None
        if lu is not None:
            from scipy.linalg import lu_solve

            factors = lu

            def refine(r: np.ndarray) -> np.ndarray:
                return np.asarray(lu_solve(factors, r, check_finite=False))

        old_prec = flint.ctx.prec
        flint.ctx.prec = COST_PRECISION
        try:
            cost, box = _cost_enclosure(_Balls(sys), Y, c, list(fl.mats(sol[:, 1])), noise, refine)
        finally:
            flint.ctx.prec = old_prec
        return Certified("stable", STABLE_CERTIFICATE, rho, (lo, hi), cost, box)
    finite = sol is not None and bool(np.all(np.isfinite(sol[:, 0])))
    indefinite = finite and sol is not None and verify_indefinite(balls, list(fl.mats(sol[:, 0])), INDEFINITE_SCALE)
    if not enclose:
        if indefinite:
            return Certified("unstable", INDEFINITE_CERTIFICATE, float("nan"), None, None, None)
        return _unstable_only(balls, fl)
    rho, cands = _candidates(fl)
    ceil = _upper_from_identity(balls)
    floor = INDEFINITE_SCALE if indefinite else Fraction(0)
    lo, hi = _radius_bounds(balls, rho, cands, floor, ceil, upper=True) if rho > 1 else (floor, ceil)
    if lo > 1:
        return Certified(
            "unstable", UNSTABLE_CERTIFICATE if lo > floor else INDEFINITE_CERTIFICATE, rho, (lo, hi), None, None
        )
    return Certified(None, "none", rho, (Fraction(0), ceil), None, None)


def _unstable_only(balls: _Balls, fl: _Floats) -> Certified:
    """The instability proof alone (no enclosure): ``T(Z) >= r Z`` for some ``1 < r < rho``, ``T`` first, then ``T*``."""
    rho = float("nan")
    for adjoint in (False, True):
        rho_side, v = _perron(fl, adjoint)
        rho = rho_side if np.isfinite(rho_side) else rho
        Z = _perron_matrices(fl, v)
        if Z is None or not Z[0].size or not rho_side > 1:
            continue
        low = min(float(np.linalg.eigvalsh(X)[0]) for X in Z)
        if low <= -1e-8:
            continue
        Z = [X + (max(0.0, -2 * low) + 1e-12) * np.eye(X.shape[0]) for X in Z]
        w = _whitened(balls, Z, adjoint)
        for part in (Fraction(1, 2), Fraction(1, 8), Fraction(1, 64)):  # any r > 1 proves instability
            r = 1 + part * (_fraction(rho_side) - 1)
            if verify_growth(balls, Z, r, adjoint) or (w is not None and verify_growth(w[0], w[1], r, adjoint)):
                return Certified("unstable", UNSTABLE_CERTIFICATE, rho_side, None, None, None)
    return Certified(None, "none", rho, None, None, None)


__all__ = ["Certified", "certify", "definite", "verify_decay", "verify_growth", "verify_indefinite", "verify_stable"]
