"""Affine symmetry of one sensor's matroid: listing its flats once per orbit of ``n -> a n + b``.

With one row per phase, ``r_n = c diag(omega^n)`` and ``omega_j =
zeta^{e_j}``, a set of phases is blind iff a non-zero word of the cyclic
code spanned by the characters ``n -> zeta^{e n}`` (``e`` in the exponents
``E``) vanishes on it; ``c`` only rescales the coordinates.  For a real
plant of cyclotomic blocks ``E`` is closed under multiplication by the
units of ``Z/N0`` (the roots of ``Phi_m`` are all primitive ``m``-th
roots), so ``n -> a n`` maps blind sets to blind sets and flats to flats:
the matroid is invariant under the affine group ``n -> a n + b`` (``a`` a
unit), ``N0 phi(N0)`` maps instead of the ``N0`` rotations (MacWilliams
and Sloane 1977, chapter 8: the automorphisms of cyclic codes).

:func:`unit_symmetries` finds the units ``a`` for which the rows of the
permuted phases are those of the phases themselves times one invertible
matrix (a scalar per phase allowed), numerically, so nothing is assumed of
the block.  :class:`Affine` is the group they generate with the
rotations: its *lex-first* test cuts every subtree of the closure walk
none of whose flats is the lexicographically first member of its orbit
(the one holding the earliest phases), and :meth:`Affine.rotation_orbits`
turns one flat per affine orbit back into one flat per shift orbit, which
is what the two-sensor proof checks (a shift moves both sensors; a unit
multiple does not map the other sensor's rows to themselves).
"""

from __future__ import annotations

import math

import numpy as np

from ._blind import SlotSpace

#: Most phases of the lex-first test: the packed prefix is a float64 integer below ``2**52``.
_PREFIX = 52

#: Relative residual within which a unit multiple counts as a symmetry of the rows.
_RTOL = 1e-10


def _basis(rows: np.ndarray) -> list[int] | None:
    """Greedy phases whose rows are independent and span every row (``None``: the rows do not span)."""
    L = rows.shape[1]
    picked: list[int] = []
    U = np.zeros((0, L), dtype=rows.dtype)  # orthonormal rows spanning the rows picked
    scale = max(1.0, float(np.abs(rows).max()))
    for n in range(rows.shape[0]):
        # The part of the row orthogonal to those picked (Hermitian products: complex rows too).
        r = rows[n] - (rows[n] @ U.conj().T) @ U if U.shape[0] else rows[n]
        size = float(np.linalg.norm(r))
        if size > 1e-6 * scale:
            picked.append(n)
            U = np.concatenate([U, (r / size)[None, :]])
            if len(picked) == L:
                return picked
    return None


def unit_symmetries(space: SlotSpace) -> tuple[int, ...]:
    """The units ``a`` of ``Z/N0`` with ``r_{a n} = t_n r_n M_a`` for every phase (one group, one row a phase).

    In the coordinates ``lambda_n = r_n R_B^{-1}`` of a basis ``B`` of
    phases, ``r_{a n} = t_n r_n M`` for scalars ``t_n != 0`` and an
    invertible ``M`` iff ``lambda'_n = t_n lambda_n diag(tau)`` (``lambda'``
    the coordinates of the permuted rows in the permuted basis, ``tau_j !=
    0``): then ``M = R_B^{-1} diag(tau) R'_B``.  Every set ``F`` and ``a F``
    then have the same rank, so ``n -> a n`` is an automorphism of the
    matroid.  ``(1,)`` when the rows are not one a phase or do not span.
    """
    N0 = space.n_phases
    if space.n_groups != 1 or space.rows.shape[1] != 1 or N0 < 3:
        return (1,)
    rows = space.rows[:, 0, :]
    B = _basis(rows)
    if B is None:
        return (1,)
    lam = np.linalg.solve(rows[B].T, rows.T).T  # lambda_n R_B = r_n
    zero = np.abs(lam) <= 1e-8 * np.abs(lam).max(axis=1, keepdims=True)
    out = [1]
    for a in range(2, N0):
        if math.gcd(a, N0) != 1:
            continue
        moved = rows[(a * np.arange(N0)) % N0]
        if not np.linalg.cond(moved[B]) <= 1e8:  # also a NaN condition number
            continue
        lam2 = np.linalg.solve(moved[B].T, moved.T).T
        zero2 = np.abs(lam2) <= 1e-8 * np.abs(lam2).max(axis=1, keepdims=True)
        if np.array_equal(zero, zero2) and _rank_one_ratio(lam, lam2, ~zero):
            out.append(a)
    return tuple(out)


def _rank_one_ratio(lam: np.ndarray, lam2: np.ndarray, support: np.ndarray) -> bool:
    """Whether ``lam2 = diag(t) lam diag(tau)`` on ``support`` for some non-zero ``t``, ``tau`` (to :data:`_RTOL`).

    ``t_n tau_j = lam2_nj / lam_nj`` on the support: ``tau`` of one column
    is set to 1 and the rest follow along the support (rows and columns
    linked by a non-zero entry); the support must link every column.
    """
    N, L = lam.shape
    ratio = np.where(support, lam2 / np.where(support, lam, 1.0), 0.0)
    tau = np.full(L, np.nan, dtype=complex)
    t = np.full(N, np.nan, dtype=complex)
    tau[0] = 1.0
    for _ in range(N + L):
        known = ~np.isnan(tau)
        if known.all():
            break
        # rows with a known column: their t from the first such column
        rows_ok = (support & known[None, :]).any(axis=1) & np.isnan(t)
        for n in np.flatnonzero(rows_ok):
            j = np.flatnonzero(support[n] & known)[0]
            t[n] = ratio[n, j] / tau[j]
        have = ~np.isnan(t)
        cols = (support & have[:, None]).any(axis=0) & ~known
        if not cols.any():
            return False  # the support does not link every column
        for k in np.flatnonzero(cols):
            m = np.flatnonzero(support[:, k] & have)[0]
            tau[k] = ratio[m, k] / t[m]
    if np.isnan(tau).any():
        return False
    pred = lam * tau[None, :]
    scale = (pred * pred.conj()).real.sum(axis=1)
    t = (lam2 * pred.conj()).sum(axis=1) / np.maximum(scale, 1e-300)
    err = np.abs(lam2 - t[:, None] * pred).max(axis=1) / np.abs(lam2).max(axis=1)
    return bool(err.max() <= _RTOL and (np.abs(tau) > 0).all())


class Affine:
    """The maps ``g(n) = a (n - b)`` of ``Z/N0`` (``a`` in ``units``, every ``b``), for flats of one group.

    ``weights[n, g] = 2^(P - 1 - g(n))`` when ``g(n) < P`` (else 0), with
    ``P = min(N0, 52)``: ``mask @ weights`` packs the first ``P`` phases of
    every image ``g(mask)`` into an exact float64 integer, earliest phase
    highest, so the largest image is the lexicographically first.
    """

    def __init__(self, n_phases: int, units: tuple[int, ...]) -> None:
        self.n_phases, self.units = n_phases, units
        N0 = n_phases
        P = min(N0, _PREFIX)
        self.prefix = P
        n = np.arange(N0)
        images = np.array([(a * (n - b)) % N0 for a in units for b in range(N0)]).T  # (N0, G): g(n)
        self.weights = np.where(images < P, np.ldexp(1.0, P - 1 - np.minimum(images, P - 1)), 0.0)
        self.identity = np.where(n < P, np.ldexp(1.0, P - 1 - np.minimum(n, P - 1)), 0.0)
        self.perms = np.array([(a * n) % N0 for a in units])  # mask[perm] is the mask of a^{-1} F
        # nearest[d]: the earliest phase a unit multiple of d reaches, either way round (d != 0).
        multiples = np.array([(a * n) % N0 for a in units])
        nearest = np.minimum(multiples, (-multiples) % N0).min(axis=0)
        nearest[0] = N0
        self.nearest = nearest

    @property
    def trivial(self) -> bool:
        """Only the rotations (no unit other than 1)."""
        return len(self.units) == 1

    def lex_first_possible(self, masks: np.ndarray, cores: np.ndarray) -> np.ndarray:
        """Whether some flat ``D`` below each flat ``Q`` (core ``c``) may be lex-first in its orbit.

        Below ``Q`` every ``D`` holds ``Q`` and agrees with it on the phases
        ``<= c``.  If for some ``g`` the first phase ``t <= c`` at which
        ``g(Q)`` and ``Q`` differ is held by ``g(Q)``, then ``g(D)`` (which
        holds ``g(Q)``) agrees with ``D`` before ``t`` where ``D`` holds a
        phase, holds ``t`` while ``D`` does not, and so comes first: no
        ``D`` is lex-first.  With the packed prefixes of :class:`Affine`
        that is ``floor(v_g / 2^k) > floor(v_1 / 2^k)``, ``k = P - 1 - c``
        (the phases after ``c`` dropped), for the largest ``v_g``.
        """
        if masks.shape[0] == 0:
            return np.ones(0, dtype=bool)
        Q = masks.astype(float)
        best = (Q @ self.weights).max(axis=1)
        own = Q @ self.identity
        k = self.prefix - 1 - np.minimum(cores, self.prefix - 1)
        scale = np.ldexp(1.0, -k)
        return np.asarray(np.floor(best * scale) <= np.floor(own * scale))

    def pairs_possible(self, Q: np.ndarray, b: np.ndarray, e: np.ndarray) -> np.ndarray:
        """Cheap necessary test of :meth:`lex_first_possible` for ``Q[b] + e`` with core ``e``, before its closure.

        A lex-first ``D`` holds phase 0 (a shift maps any phase of ``D``
        there), and its second phase ``s`` is at most ``a (y - x)`` for
        every two phases ``x, y`` of ``D`` and unit ``a`` (``n -> a (n - x)``
        maps ``x, y`` to ``0, a (y - x)``).  Below ``Q[b] + e`` the second
        phase is decided: the first phase of ``Q[b]`` after 0, or ``e`` if
        earlier; so every pair ``(e, q)`` needs ``nearest[e - q] >= s``.
        """
        N0 = self.n_phases
        phases = np.arange(N0)
        has0 = Q[b, 0] | (e == 0)
        later = Q[:, 1:]
        first = np.where(later.any(axis=1), np.argmax(later, axis=1) + 1, N0)
        s = np.where(e == 0, 1, np.minimum(first[b], e))
        reach = np.where(Q[b], self.nearest[(e[:, None] - phases[None, :]) % N0], N0)
        return np.asarray(has0 & (reach.min(axis=1) >= s))

    def rotation_orbits(self, masks: list[np.ndarray], seen: set[bytes]) -> list[tuple[np.ndarray, int, int]]:
        """One mask per shift orbit among the unit multiples of ``masks`` not in ``seen``: ``(mask, i, u)``.

        ``mask`` is ``a^{-1} F`` for ``F = masks[i]`` and ``a = units[u]``
        (``u = 0``: ``F`` itself); two are kept apart unless a rotation maps
        one onto the other (keyed by the largest rotation of their packed
        bits, :func:`_rotation_keys`), and the keys kept join ``seen``.
        """
        out: list[tuple[np.ndarray, int, int]] = []
        if not masks:
            return out
        M = np.stack(masks)
        for u in range(len(self.units)):
            moved = M[:, self.perms[u]]
            for i, key in enumerate(_rotation_keys(moved)):
                if key not in seen:
                    seen.add(key)
                    out.append((moved[i], i, u))
        return out


#: Phases packed in one exact float64 integer by :func:`_rotation_keys`.
_WORD = 42


def _rotation_keys(masks: np.ndarray) -> list[bytes]:
    """Per mask (one group), the packed bits of its largest rotation: equal iff the masks are one shift orbit.

    The phases are packed in exact float64 integers of :data:`_WORD` bits
    (earliest highest), for every rotation at once by one matrix product
    per word; the largest rotation has the largest first word, ties broken
    by the next.
    """
    C, N0 = masks.shape
    M = masks.astype(float)
    alive = np.ones((C, N0), dtype=bool)  # rotations still tied for the largest
    words = []
    for w in _rotation_weights(N0):
        value = np.where(alive, M @ w, -1.0)  # (C, N0): rotation k moves phase n to n - k
        top = value.max(axis=1)
        alive &= value == top[:, None]
        words.append(top)
    return [row.tobytes() for row in np.stack(words, axis=1)]


def _rotation_weights(N0: int) -> list[np.ndarray]:
    """Per word ``j``: ``w[n, k] = 2^(_WORD - 1 - i)`` when ``(n - k) mod N0 = j _WORD + i``, ``0 <= i < _WORD``."""
    n = np.arange(N0)
    m = (n[:, None] - n[None, :]) % N0
    out = []
    for j in range(0, N0, _WORD):
        i = m - j
        out.append(np.where((i >= 0) & (i < _WORD), np.ldexp(1.0, _WORD - 1 - np.clip(i, 0, _WORD - 1)), 0.0))
    return out
