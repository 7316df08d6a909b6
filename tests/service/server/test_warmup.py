"""The forkserver preload warms the workers: after it, a seed-system analysis imports nothing new.

Counted, not timed: the modules a first request would otherwise import (SymPy's sub-modules
among them) are already in ``sys.modules`` of every forked worker.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from kfio.service.jobs import PRELOAD

CHILD = r"""
import json, sys
import kfio.service.warmup as w
from kfio import analyze, load_request
from kfio.service.api.schemas import REQUEST_EXAMPLES
before = set(sys.modules)
for key in ("seed004-scalar", "seed004-3x3", "seed002-2x2"):
    body = dict(REQUEST_EXAMPLES[key]["value"])
    body.pop("options", None)
    body["channel"] = {"model": "bernoulli", "arrival_probability": "600053/1000000"}
    analyze(load_request(json.dumps(body)))
print(json.dumps({"warm": w.WARMUP_CPU_SECONDS > 0, "new": sorted(set(sys.modules) - before)}))
"""


def test_warmup_is_preloaded_last() -> None:
    assert PRELOAD[-1] == "kfio.service.warmup"


@pytest.mark.slow  # a fresh interpreter imports all of kfio and runs the warm-up (about 10 s of CPU)
def test_after_the_warmup_a_seed_analysis_imports_no_module() -> None:
    out = subprocess.run([sys.executable, "-c", CHILD], check=True, capture_output=True, text=True, timeout=300)
    res = json.loads(out.stdout.strip().splitlines()[-1])
    assert res["warm"], out.stderr
    assert res["new"] == []
