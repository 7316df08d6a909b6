"""Work budgets: long computations check in and stop with :class:`BudgetExceeded`.

A budget is cooperative: loops that may run long call :meth:`Budget.tick`.
The HTTP service additionally runs each request in a worker process it can
kill, so a computation that never checks in still cannot take it down.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from .errors import BudgetExceeded


@dataclass
class Budget:
    """Wall-clock and step budget.

    Parameters
    ----------
    seconds:
        Wall-clock allowance from creation, or ``None`` for no limit.
    max_steps:
        Allowance of :meth:`tick` steps (summed over all loops), or ``None``.
    """

    seconds: float | None = None
    max_steps: int | None = None
    steps: int = 0
    _start: float = field(default_factory=time.monotonic, repr=False)

    def tick(self, what: str, n: int = 1) -> None:
        """Account ``n`` steps of ``what``; raise once the budget is spent."""
        self.steps += n
        if self.max_steps is not None and self.steps > self.max_steps:
            raise BudgetExceeded(f"{what}: more than {self.max_steps} steps")
        # The clock is read at every tick (tens of nanoseconds): one step may be a large C call
        # (an eigendecomposition of a 1024 x 1024 matrix), so checking every 64th could overrun by minutes.
        if self.seconds is not None:
            if time.monotonic() - self._start > self.seconds:
                raise BudgetExceeded(f"{what}: more than {self.seconds:g} s")

    def remaining(self) -> float | None:
        if self.seconds is None:
            return None
        return max(0.0, self.seconds - (time.monotonic() - self._start))
