"""kfio._workers: the process mechanics every pool shares (no wall-clock assertions: a task ends or is killed)."""

from __future__ import annotations

import faulthandler
import os
import signal
import time

import pytest

from kfio._workers import ALLOCATION_SIGNALS, Died, died_of_allocation, run_all


def _echo(value: object, budget_s: float | None) -> tuple[object, float | None, int]:
    return value, budget_s, os.getpid()


def _forever(_value: object, _budget_s: float | None) -> None:
    while True:
        time.sleep(1)


def _die(sig: int, _budget_s: float | None) -> None:
    faulthandler.disable()  # no traceback of pytest's handler on stderr for the planted crash
    if sig:
        os.kill(os.getpid(), sig)
    os._exit(3)


def test_every_task_is_answered_with_its_args_and_budget_in_another_process() -> None:
    seen: list[tuple[int, int]] = []
    tasks = [((k,), 0.5 + k) for k in range(5)]
    done = run_all(_echo, tasks, workers=2, deadline=None, progress=lambda d, n: seen.append((d, n)))
    assert {k: v[:2] for k, v in done.items()} == {k: (k, 0.5 + k) for k in range(5)}
    pids = {v[2] for v in done.values()}
    assert os.getpid() not in pids and 1 <= len(pids) <= 2  # two workers took turns
    assert seen == [(d, 5) for d in range(1, 6)]


def test_the_deadline_kills_what_still_computes_and_leaves_it_unanswered() -> None:
    done = run_all(_forever, [((0,), None), ((1,), None)], workers=2, deadline=time.monotonic() + 0.5)
    assert done == {}


def test_a_worker_that_dies_is_reported_and_replaced() -> None:
    tasks = [((signal.SIGABRT,), None), ((0,), None), ((int(signal.SIGTERM),), None)]
    done = run_all(_die, tasks, workers=1, deadline=None, memory_bytes=1 << 40)
    assert done == {
        0: Died(-signal.SIGABRT, out_of_memory=True),  # a failed C allocation under a memory limit aborts
        1: Died(3, out_of_memory=False),
        2: Died(-signal.SIGTERM, out_of_memory=False),
    }


@pytest.mark.parametrize("sig", sorted(ALLOCATION_SIGNALS))
def test_allocation_deaths_count_only_under_a_memory_limit(sig: int) -> None:
    assert died_of_allocation(-sig, 1 << 30) and not died_of_allocation(-sig, None)
    assert not died_of_allocation(-signal.SIGKILL, 1 << 30) and not died_of_allocation(1, 1 << 30)
