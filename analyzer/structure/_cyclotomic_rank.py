"""Exact ranks over a cyclotomic field ``Q(zeta_L)`` at FLINT speed: a bound from below and a kernel certificate.

The rows of a reduced FMO block whose members are ``theta_j = r zeta_L^(k_j)``
(``r`` rational) are ``c_ij omega_j^n`` with ``omega_j = zeta_L^(a_j)``
(Rohr, Marelli and Fu (2014), Definition 4).  Elements of ``K = Q(zeta_L)``
are polynomials in ``y`` reduced modulo the cyclotomic polynomial ``Phi_L``
(FLINT ``fmpq_poly``); no per-element SymPy arithmetic.

Rank from below.  For a prime ``p = 1 (mod L)`` the polynomial ``Phi_L``
splits into ``d = phi(L)`` distinct linear factors modulo ``p``, and each
root ``z`` gives a ring homomorphism ``zeta_L -> z`` onto ``F_p`` of the
``p``-integral elements.  A minor non-zero modulo ``p`` is non-zero, so the
rank modulo ``p`` never exceeds the rank over ``K``.

Rank from above.  Scaling column ``j`` by a non-zero ``s_j`` changes no rank;
with ``s_j`` the column's first non-zero entry, one output row leaves pure
roots of unity (small kernel vectors).  With ``r`` the rank modulo ``p`` and
``F`` the non-pivot columns of the reduced echelon form, each ``f`` in ``F``
has the kernel vector ``x_f = 1``, ``x_g = 0`` (other ``g`` in ``F``),
``x_pivot = -rref[., f]``.  Its images under all ``d`` homomorphisms of one
prime are interpolated into its coefficients modulo ``p``; several primes are
combined by the Chinese remainder theorem and rational reconstruction, and
the vectors are checked exactly: ``M x = 0`` over ``K``.  ``|F|``
independent verified kernel vectors prove rank ``<= r``; with the bound from
below the rank is exactly ``r``.  Whatever the primes, a returned rank is
proved; when no certificate is found within :data:`MAX_PRIMES` primes the
rank is decided by Gaussian elimination over ``K`` (slow, exact).
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Iterable, Iterator, Sequence

import flint
from flint import fmpq, fmpq_poly, nmod_mat

from ._phases import Slot

#: Primes ``1 (mod L)`` are taken downwards from here (``nmod_mat`` works in machine words).
_START = 2**62

#: Primes combined before the kernel certificate gives way to elimination over ``K``.
MAX_PRIMES = 48


def cyclotomic(L: int) -> fmpq_poly:
    """``Phi_L`` as an ``fmpq_poly``."""
    return fmpq_poly([int(c) for c in flint.fmpz_poly.cyclotomic(L).coeffs()])


def _prime_factors(n: int) -> list[int]:
    """The distinct primes dividing ``n >= 1``, increasing (FLINT's factorisation)."""
    return [int(q) for q, _ in flint.fmpz(n).factor()]


class _Prime:
    """A prime ``p = 1 (mod L)``, the ``d`` roots of ``Phi_L`` modulo ``p`` and the inverse Vandermonde matrix."""

    def __init__(self, p: int, L: int) -> None:
        self.p = p
        qs = _prime_factors(L)
        a = 2
        while True:
            z = pow(a, (p - 1) // L, p)
            if all(pow(z, L // q, p) != 1 for q in qs):
                break
            a += 1
        # roots in the order of the exponents u coprime to L
        self.roots = [pow(z, u, p) for u in range(1, L + 1) if math.gcd(u, L) == 1]
        d = len(self.roots)
        V = nmod_mat(d, d, [pow(x, i, p) for x in self.roots for i in range(d)], p)
        self.inverse_vandermonde = V.inv()
        # powers[k][e] = roots[k]^e, e in [0, L)
        self.powers = [[pow(x, e, p) for e in range(L)] for x in self.roots]

    def image(self, a: fmpq_poly, k: int) -> int | None:
        """``a(z_k) mod p``, ``None`` if a denominator of ``a`` has ``p``."""
        p = self.p
        den = int(a.denom()) % p
        if den == 0:
            return None
        pw = self.powers[k]
        L = len(pw)
        acc = 0
        for i, c in enumerate(a.numer().coeffs()):
            acc += int(c) * pw[i % L]
        return acc * pow(den, -1, p) % p


def _primes(L: int) -> Iterator[_Prime]:
    """Primes ``1 (mod L)`` below :data:`_START`, largest first."""
    k = (_START - 2) // L
    while k > 0:
        p = k * L + 1
        if flint.fmpz(p).is_prime():
            yield _Prime(p, L)
        k -= 1


def _rational(a: int, m: int) -> Fraction | None:
    """Rational reconstruction: ``n / d = a (mod m)`` with ``|n|, d <= sqrt(m / 2)``, or ``None``."""
    bound = math.isqrt(m // 2)
    r0, r1, s0, s1 = m, a % m, 0, 1
    while r1 > bound:
        q = r0 // r1
        r0, r1 = r1, r0 - q * r1
        s0, s1 = s1, s0 - q * s1
    if s1 == 0 or abs(s1) > bound or math.gcd(r1, abs(s1)) != 1:
        return None
    return Fraction(r1, s1)


class CyclotomicRows:
    """Exact rank oracle of a block with rows ``c_ij zeta_L^(a_j n)`` over ``K = Q(zeta_L)``.

    ``columns[j][i]`` is ``c_ij`` as a polynomial in ``zeta_L`` (reduced
    modulo ``Phi_L``); ``exponents[j]`` is ``a_j``; ``groups`` the row
    groups; ``period`` the base period ``N0`` (rows depend on ``n mod N0``).
    Called with slots ``(n, g)``, returns the exact rank of the stacked rows
    (module docstring).
    """

    def __init__(
        self,
        L: int,
        columns: Sequence[Sequence[fmpq_poly]],
        exponents: Sequence[int],
        groups: Sequence[Sequence[int]],
        period: int,
    ) -> None:
        self.L = L
        self.phi = cyclotomic(L)
        self.d = self.phi.degree()
        self.groups = groups
        self.period = period
        self.exponents = [a % L for a in exponents]
        self.n_columns = len(columns)
        self.p = len(columns[0]) if columns else 0
        # scale each column by its first non-zero entry: ratios[j][i] = c_ij / s_j
        self.ratios: list[list[fmpq_poly]] = []
        for col in columns:
            s = next((c for c in col if not c.is_zero()), None)
            if s is None:
                self.ratios.append([fmpq_poly(0)] * self.p)
                continue
            inv = self._inverse(s)
            self.ratios.append([fmpq_poly(1) if c == s else (c * inv) % self.phi for c in col])
        self._unit_ratios = all(c.is_one() for col in self.ratios for c in col)
        self._monomials = [fmpq_poly([0] * e + [1]) for e in range(L)]
        self._prime_list: list[_Prime] = []
        self._prime_iter = _primes(L)
        self._reduced: dict[int, list[list[list[int]]] | None] = {}
        self._cache: dict[tuple[tuple[int, int], ...], int] = {}

    def _inverse(self, a: fmpq_poly) -> fmpq_poly:
        """``1 / a`` in ``K`` (``a`` non-zero modulo the irreducible ``Phi_L``): Bezout's identity."""
        g, s, _ = a.xgcd(self.phi)
        return (s / g) % self.phi

    def _prime(self, index: int) -> _Prime:
        while len(self._prime_list) <= index:
            self._prime_list.append(next(self._prime_iter))
        return self._prime_list[index]

    def _images(self, index: int) -> list[list[list[int]]] | None:
        """Per root ``z_k`` of prime ``index``: the images ``[j][i]`` of the ratios, ``None`` if one does not reduce."""
        if index not in self._reduced:
            P = self._prime(index)
            out = []
            for k in range(self.d):
                per = []
                for col in self.ratios:
                    imgs = [P.image(c, k) for c in col]
                    if any(x is None for x in imgs):
                        self._reduced[index] = None
                        return None
                    per.append([int(x) for x in imgs if x is not None])
                out.append(per)
            self._reduced[index] = out
        return self._reduced[index]

    def _row_keys(self, slots: Sequence[Slot]) -> list[tuple[int, int]]:
        return [(n % self.period, i) for n, g in slots for i in self.groups[g]]

    def _matrix(self, index: int, k: int, keys: Sequence[tuple[int, int]]) -> nmod_mat | None:
        """The stacked rows (scaled columns) under root ``k`` of prime ``index``."""
        images = self._images(index)
        if images is None:
            return None
        P = self._prime(index)
        pw, img, L, p = P.powers[k], images[k], self.L, P.p
        ex = self.exponents
        if self._unit_ratios:  # every entry a power of zeta (one row, scaled columns): no products
            flat = [pw[ex[j] * n % L] for n, _ in keys for j in range(self.n_columns)]
        else:
            flat = [img[j][i] * pw[ex[j] * n % L] % p for n, i in keys for j in range(self.n_columns)]
        return nmod_mat(len(keys), self.n_columns, flat, p)

    def __call__(self, slots: Iterable[Slot]) -> int:
        keys = self._row_keys(list(slots))
        if not keys:
            return 0
        key = tuple(sorted(set(keys)))
        if key not in self._cache:
            self._cache[key] = self._rank(list(key))
        return self._cache[key]

    def _rank(self, keys: list[tuple[int, int]]) -> int:
        L = self.n_columns
        index = 0
        while (M := self._matrix(index, 0, keys)) is None:
            index += 1
        low = int(M.rank())
        if low == L:
            return L
        return self._certified(keys, low)

    def _certified(self, keys: list[tuple[int, int]], low: int) -> int:
        """The rank, given ``low`` from below: kernel vectors from primes, verified over ``K``."""
        L = self.n_columns
        modulus = 1
        residues: list[list[int]] | None = None  # per kernel coordinate: coefficients mod `modulus`
        pivots: list[int] | None = None
        used = 0
        for index in range(MAX_PRIMES):
            P = self._prime(index)
            values = []
            ok = True
            for k in range(self.d):
                M = self._matrix(index, k, keys)
                if M is None:
                    ok = False
                    break
                R, rank = M.rref()
                rank = int(rank)
                if rank > low:  # a better bound from below: start again
                    return self._certified(keys, rank)
                entries = [int(x) for x in R.entries()]
                piv = []
                for t in range(rank):
                    row = entries[t * L : (t + 1) * L]
                    piv.append(next(j for j, x in enumerate(row) if x))
                if rank < low or (pivots is not None and piv != pivots):
                    ok = False
                    break
                if pivots is None:
                    pivots = piv
                free = [j for j in range(L) if j not in piv]
                # kernel coordinates: for each free f and pivot row t, -rref[t][f]
                values.append([(-entries[t * L + f]) % P.p for f in free for t in range(rank)])
            if not ok or pivots is None:
                continue
            n_coords = len(values[0])
            Y = nmod_mat(self.d, n_coords, [v for per in values for v in per], P.p)
            coeffs = P.inverse_vandermonde * Y  # d x n_coords: coefficient i of each coordinate
            flat = [int(x) for x in coeffs.entries()]
            new = [[flat[i * n_coords + c] for i in range(self.d)] for c in range(n_coords)]
            if residues is None:
                residues, modulus = new, P.p
            else:
                m2 = P.p
                inv = pow(modulus, -1, m2)
                residues = [
                    [a + modulus * ((b - a) * inv % m2) for a, b in zip(old, cur)] for old, cur in zip(residues, new)
                ]
                modulus *= m2
            used += 1
            if used & (used - 1) == 0 or used >= 4:  # try after 1, 2, 4, then every prime
                vectors = self._reconstruct(residues, modulus, pivots)
                if vectors is not None and self._verify(keys, vectors):
                    return low
        return self._eliminate(keys)

    def _reconstruct(self, residues: list[list[int]], modulus: int, pivots: list[int]) -> list[list[fmpq_poly]] | None:
        """Kernel vectors over ``K`` from coefficients modulo ``modulus``, ``None`` if a reconstruction fails."""
        L, rank = self.n_columns, len(pivots)
        free = [j for j in range(L) if j not in pivots]
        bound = math.isqrt(modulus // 2)
        den = 1
        polys: list[fmpq_poly] = []
        for coeffs in residues:
            out = []
            for a in coeffs:
                w = a * den % modulus
                if w > modulus // 2:
                    w -= modulus
                if den <= bound and abs(w) <= bound:
                    out.append(Fraction(w, den))
                    continue
                q = _rational(a, modulus)
                if q is None:
                    return None
                den = den * q.denominator // math.gcd(den, q.denominator)
                out.append(q)
            polys.append(fmpq_poly([fmpq(c.numerator, c.denominator) for c in out]))
        vectors = []
        for fi, f in enumerate(free):
            x = [fmpq_poly(0)] * L
            x[f] = fmpq_poly(1)
            for t in range(rank):
                x[pivots[t]] = polys[fi * rank + t]
            vectors.append(x)
        return vectors

    def _verify(self, keys: Sequence[tuple[int, int]], vectors: Sequence[Sequence[fmpq_poly]]) -> bool:
        """``M x = 0`` over ``K`` for every vector: exact, in ``Q[y] / Phi_L``."""
        L, mono, ex = self.L, self._monomials, self.exponents
        for x in vectors:
            terms = [(j, self.ratios[j], x[j]) for j in range(self.n_columns) if not x[j].is_zero()]
            for n, i in keys:
                acc = fmpq_poly(0)
                for j, col, xj in terms:
                    c = col[i]
                    if c.is_zero():
                        continue
                    acc += (xj if c.is_one() else c * xj) * mono[ex[j] * n % L]
                if not (acc % self.phi).is_zero():
                    return False
        return True

    def _eliminate(self, keys: Sequence[tuple[int, int]]) -> int:
        """Rank by Gaussian elimination over ``K`` (exact; the fallback when no certificate was found)."""
        L, mono, ex, phi = self.L, self._monomials, self.exponents, self.phi
        rows = [[(self.ratios[j][i] * mono[ex[j] * n % L]) % phi for j in range(self.n_columns)] for n, i in keys]
        rank = 0
        for c in range(self.n_columns):
            piv = next((t for t in range(rank, len(rows)) if not rows[t][c].is_zero()), None)
            if piv is None:
                continue
            rows[rank], rows[piv] = rows[piv], rows[rank]
            inv = self._inverse(rows[rank][c])
            top = [(e * inv) % phi for e in rows[rank]]
            rows[rank] = top
            for t in range(rank + 1, len(rows)):
                a = rows[t][c]
                if not a.is_zero():
                    rows[t] = [(u - a * v) % phi for u, v in zip(rows[t], top)]
            rank += 1
        return rank
