"""Worker replacement does not wait for the threads that request handlers use.

Reproducer: sweep validations filled the event loop's default executor; a
killed worker was then counted "replaced: 1" while the pool stayed at
"alive: 1" for as long as the executor stayed full, because spawning the
replacement queued behind them.  Here the default executor is blocked
outright, and a crashed worker must still be replaced and serve the next task.
"""

from __future__ import annotations

import asyncio
import os
import threading
from concurrent.futures import ThreadPoolExecutor

from kfio.service.jobs import PRELOAD
from kfio.service.pool import WorkerCrashed, WorkerPool

HERE = __name__  # the workers import this module to find the runner below


def echo_or_exit(code: int, budget_s: float) -> str:
    if code:
        os._exit(code)
    return "ok"


def test_a_crashed_worker_is_replaced_while_the_default_executor_is_blocked() -> None:
    async def scenario() -> None:
        loop = asyncio.get_running_loop()
        blocked = ThreadPoolExecutor(1, thread_name_prefix="blocked")
        loop.set_default_executor(blocked)
        release = threading.Event()
        p = WorkerPool(1, f"{HERE}:echo_or_exit", preload=PRELOAD)
        await p.start()
        hog = loop.run_in_executor(None, release.wait, 120)  # the only default thread, held
        try:
            try:
                await p.run((5,), budget_s=30)
            except WorkerCrashed:
                pass
            else:  # pragma: no cover - the runner exits
                raise AssertionError("the worker should have died")
            # the next task needs the replacement, which needs a thread: not the blocked one
            assert await asyncio.wait_for(p.run((0,), budget_s=30), timeout=60) == "ok"
            assert p.stats()["replaced"] == 1 and p.stats()["alive"] == 1
            assert not hog.done()  # the default executor was held throughout
        finally:
            release.set()
            await hog
            await p.close()

    asyncio.run(scenario())
