"""A reduced FMO block in phase form: the input of the sigma computation.

Rohr, Marelli and Fu (2014), Definition 4 reduces an FMO block to ``(A_hat, C_hat)`` with
``A_hat = alpha * diag(omega_1, ..., omega_L)``, one ``omega_j`` per Jordan
chain, every ``omega_j`` a root of unity.  With ``N0`` the least common order
of the ``omega_j``, write ``omega_j = exp(2 pi i e_j / N0)``.  The row block
seen at phase ``n`` (time ``t = n mod N``) is

    r_n = C_hat diag(omega^n)           (docs/theory.md, "sigma_k")

and a set ``F`` of (phase, row group) slots is *blind* when the stacked rows
``{r_n[group rows] : (n, group) in F}`` do not have full column rank ``L``.
A row group is a sensor packet; the one-packet case has a single
group holding every row.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Iterable

import numpy as np

Slot = tuple[int, int]  # (phase n in [0, N0), row group index)

#: Exact rank oracle: stacked rows for the given slots -> exact rank, or None
#: when no exact arithmetic is available for this block.
RankOracle = Callable[[Iterable[Slot]], int | None]


@dataclass(frozen=True)
class PhaseBlock:
    """Reduced FMO block in phase coordinates.

    Attributes
    ----------
    base_period:
        ``N0 >= 1``, the least common multiple of the orders of the ``omega_j``.
        The period ``N`` of Rohr, Marelli and Fu (2014) is the smallest multiple of ``N0`` that is
        ``>= max(nu, 1)``; rows depend on ``n mod N0`` only.
    exponents:
        ``e_j`` in ``[0, N0)``, one per column of ``c_hat``.
    c_hat:
        Complex ``p x L`` matrix, ``C`` applied to a basis of each eigenspace
        ``E_theta`` (columns scaled to unit norm, which changes no rank).
    row_groups:
        Partition of the ``p`` rows into packets; ``(tuple(range(p)),)`` for
        one packet.
    exact_rank:
        Optional exact rank oracle (see :data:`RankOracle`).
    """

    base_period: int
    exponents: tuple[int, ...]
    c_hat: np.ndarray
    row_groups: tuple[tuple[int, ...], ...]
    exact_rank: RankOracle | None = field(default=None, compare=False, repr=False)

    @property
    def n_columns(self) -> int:
        """``L``: the number of Jordan chains in the block."""
        return int(self.c_hat.shape[1])

    def omega_powers(self, n: int) -> np.ndarray:
        """``omega_j^n`` for every column ``j``."""
        e = np.asarray(self.exponents, dtype=float)
        return np.exp(2j * np.pi * ((e * n) % self.base_period) / self.base_period)

    def rows(self, n: int, group: int | None = None) -> np.ndarray:
        """``r_n`` (or its rows of one group): ``C_hat[rows] diag(omega^n)``."""
        ch = self.c_hat if group is None else self.c_hat[list(self.row_groups[group]), :]
        result: np.ndarray = ch * self.omega_powers(n)[None, :]
        return result

    def stacked(self, slots: Iterable[Slot]) -> np.ndarray:
        """The rows of all ``slots`` stacked, shape ``(k, L)``."""
        blocks = [self.rows(n, g) for n, g in slots]
        if not blocks:
            return np.zeros((0, self.n_columns), dtype=complex)
        return np.vstack(blocks)

    def numeric_rank(self, slots: Iterable[Slot], rtol: float = 1e-9) -> int:
        """Rank by SVD with a relative tolerance (columns have unit norm)."""
        M = self.stacked(slots)
        if M.shape[0] == 0:
            return 0
        s = np.linalg.svd(M, compute_uv=False)
        return int((s > rtol * max(1.0, s[0] if s.size else 0.0)).sum())
