"""Plants built from blocks, shared by tests and benchmarks (integer entries, exact)."""

from __future__ import annotations

from flint import fmpz_poly


def cyclotomic_companion(m: int, alpha: int = 2) -> list[list[int]]:
    """``alpha`` times the companion matrix of ``Phi_m``: eigenvalues ``alpha`` times primitive ``m``-th roots."""
    c = [int(x) for x in fmpz_poly.cyclotomic(m).coeffs()]
    d = len(c) - 1
    A = [[0] * d for _ in range(d)]
    for i in range(1, d):
        A[i][i - 1] = alpha
    for i in range(d):
        A[i][d - 1] = -alpha * c[i]
    return A


def block_diagonal(*blocks: list[list[int]]) -> list[list[int]]:
    n = sum(len(b) for b in blocks)
    A = [[0] * n for _ in range(n)]
    k = 0
    for b in blocks:
        for i, row in enumerate(b):
            A[k + i][k : k + len(row)] = row
        k += len(b)
    return A
