"""The closed-loop mutants stay in bench/mutation.py, each aimed at the multi-mode oracle tests.

Planted one at a time, each of these bugs once passed every loop, check, sweep and service
test; tests/loop/test_loop_multimode_oracle.py kills each (``python bench/mutation.py NAME``).
tests/test_mutants_catalogue.py keeps every entry applicable.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: Names only: an entry's file and text move with the code (the catalogue test keeps them applicable).
LOOP_MUTANTS = (
    "loop-operator-blocks-transposed",
    "loop-transition-transposed",
    "loop-noise-without-mode-weight",
    "loop-ge-table-swapped",
    "loop-cost-input-noise-dropped",
    "loop-definite-tolerance-sign",
    "loop-definite-negative-as-positive",
    "loop-interval-left-end-off-by-one",
    "loop-merged-right-end-off-by-one",
)


def _mutants():
    spec = importlib.util.spec_from_file_location("kfio_bench_mutation_loop", ROOT / "bench" / "mutation.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return {m.name: m for m in module.MUTANTS}


def test_the_closed_loop_mutants_are_listed_with_the_oracle_tests():
    mutants = _mutants()
    for name in LOOP_MUTANTS:
        assert name in mutants, name
        assert "tests/loop/test_loop_multimode_oracle.py" in mutants[name].tests
