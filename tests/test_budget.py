"""The work budget reads the clock at every tick.

One tick can stand for a long C call, so a budget that looked at the clock
only every 64th tick could overrun by 63 such calls.  No timing here: the
budget's start is set in the past.
"""

from __future__ import annotations

import time
from fractions import Fraction

import pytest

from kfio import Budget
from kfio.errors import BudgetExceeded
from kfio.model._types import MarkovChannel
from kfio.sigma._sigma import period_transfer_matrix


def spent(seconds: float) -> Budget:
    return Budget(seconds=seconds, _start=time.monotonic() - 10 * seconds - 1)


def test_the_first_tick_past_the_budget_raises() -> None:
    with pytest.raises(BudgetExceeded, match="more than 1 s"):
        spent(1.0).tick("one long step")


def test_steps_are_counted_without_a_clock() -> None:
    b = Budget(max_steps=3)
    b.tick("a", 3)
    with pytest.raises(BudgetExceeded, match="more than 3 steps"):
        b.tick("a")


def test_exact_markov_transfer_matrix_checks_the_budget() -> None:
    # order 10: 1,024 histories, a million exact products per step; the budget stops it at once
    ch = MarkovChannel("markov", 10, tuple(Fraction(1 + h % 7, 9) for h in range(1 << 10)))
    with pytest.raises(BudgetExceeded, match="exact transfer matrices"):
        period_transfer_matrix(4, frozenset({(0, 0)}), [ch], spent(1.0))
