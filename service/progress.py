"""Progress of a job, reported from inside a worker process through a small file.

The analyzer's long loops already check in with :meth:`kfio.Budget.tick`.
:class:`ProgressBudget` is a :class:`kfio.Budget` that, besides enforcing
the time limit, writes what it has seen (the stage name, the steps counted so
far, the size of the last tick) to a JSON file at most every
``interval_s`` seconds, atomically (write then rename).  The server reads that
file when a client polls the job (:mod:`kfio.service.jobstore`); the worker
protocol of :mod:`kfio.service.pool` is untouched.

A job asks for this by putting :data:`PROGRESS_KEY` (the file's path) in its
params; :func:`budget_for` takes it out again before the job function sees them.

Examples
--------
>>> import json, tempfile, pathlib
>>> path = pathlib.Path(tempfile.mkdtemp()) / "job.progress"
>>> budget, params = budget_for(10.0, {PROGRESS_KEY: str(path), "points": 5})
>>> params
{'points': 5}
>>> budget.tick("Monte Carlo simulation", 100)
>>> json.loads(path.read_text())["steps"]
100
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from kfio import Budget

#: Key of the params of a worker job that names its progress file.
PROGRESS_KEY = "_progress_file"


@dataclass
class ProgressBudget(Budget):
    """A :class:`kfio.Budget` that also records its progress in ``path``.

    Parameters
    ----------
    path:
        File to (re)write with ``{"stage", "steps", "last_n", "elapsed_s"}``.
    interval_s:
        Least time between two writes (the first tick always writes).
    """

    path: str = ""
    interval_s: float = 0.5
    _written: float = field(default=-1.0, repr=False)

    def tick(self, what: str, n: int = 1) -> None:
        super().tick(what, n)
        now = time.monotonic()
        if self._written < 0 or now - self._written >= self.interval_s:
            self._written = now
            self._write(what, n, now)

    def _write(self, what: str, n: int, now: float) -> None:
        record = {"stage": what, "steps": self.steps, "last_n": n, "elapsed_s": round(now - self._start, 3)}
        tmp = f"{self.path}.tmp"
        try:
            with open(tmp, "w", encoding="utf-8") as fh:
                json.dump(record, fh)
            os.replace(tmp, self.path)
        except OSError:  # progress is a courtesy: never fail the work for it
            pass


def budget_for(budget_s: float, params: Mapping[str, Any]) -> tuple[Budget, dict[str, Any]]:
    """The budget of a worker job, and its params without :data:`PROGRESS_KEY`."""
    rest = dict(params)
    path = rest.pop(PROGRESS_KEY, None)
    if path:
        return ProgressBudget(seconds=budget_s, path=str(path)), rest
    return Budget(seconds=budget_s), rest


def read_progress(path: Path) -> dict[str, Any] | None:
    """What the worker last wrote to ``path``, or ``None`` (not yet written, or unreadable)."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None
