"""A search over several Bernoulli sensors cut short by its budget reports a bracket that holds sigma.

Oracle: the same block searched to the end (``compute_sigma`` with a large
budget), whose ``sigma^N0`` must lie in every bracket reported on the way;
the lower end's set must be blind (numpy rank, independent of the search).
"""

from __future__ import annotations

import json
import math
from fractions import Fraction

import numpy as np
import pytest

from kfio import analyze, load_request
from kfio._budget import Budget
from kfio.errors import BudgetExceeded
from kfio.search._blind import SlotSpace
from kfio.service.commands.analyze import partial_summary
from kfio.service.problems import problem_from_exception
from kfio.sigma import SigmaBudgetExceeded, compute_sigma
from kfio.structure import fmo_blocks

from support.blind_blocks import bench_block, random_block, rank
from support.bruteforce_sensors import bernoulli
from support.plants import block_diagonal, cyclotomic_companion

SEED = 20261203


def _true_power(res, channels, N0: int) -> Fraction:
    """``sigma^N0 = prod_g (1 - lambda_g)^{z_g}`` of a finished search."""
    assert res.bernoulli_exponents is not None
    return math.prod(
        ((1 - ch.table[0]) ** int(e * N0) for ch, e in zip(channels, res.bernoulli_exponents)), start=Fraction(1)
    )


def _brackets(block, channels, steps: int):
    """Brackets reported at several cut points before ``steps`` (the full run's ticks)."""
    out = []
    for cut in sorted({0, 1, 2, steps // 8, steps // 4, steps // 2, steps - 1}):
        try:
            compute_sigma(block, channels, Budget(max_steps=cut))
        except SigmaBudgetExceeded as exc:
            out.append(exc.bracket)
        except BudgetExceeded:
            pass  # cut outside the multi-sensor search (exact checks): nothing to bracket
    return out


@pytest.mark.parametrize("i", range(30))
def test_bracket_holds_sigma_on_random_blocks(i: int) -> None:
    rng = np.random.default_rng([SEED, i])
    groups = 3 if i % 3 == 2 else 2
    N0 = int(rng.integers(3, 7 if groups == 3 else 11))
    block = random_block(rng, N0, groups, rows=1 + (i % 5 == 4), real=i % 2 == 0)
    channels = [bernoulli(Fraction(int(rng.integers(1, 9)), 10)) for _ in range(groups)]
    full = Budget(max_steps=2_000_000)
    res = compute_sigma(block, channels, full)
    truth = _true_power(res, channels, N0)
    space = SlotSpace.from_block(block)
    for b in _brackets(block, channels, full.steps):
        assert b.phases == N0
        assert b.lower <= truth <= b.upper
        mask = space.mask(list(b.lower_set))
        assert rank(space, mask) < space.n_columns, "the lower end's set is blind"
        assert b.lower == math.prod(
            ((1 - ch.table[0]) ** z for ch, z in zip(channels, b.lower_misses)), start=Fraction(1)
        )
        if b.upper_misses is not None:
            assert all(z >= m for z, m in zip(b.lower_misses, b.upper_misses))


def test_bracket_of_a_dense_two_sensor_block_is_exact_and_tight_at_the_end() -> None:
    block = bench_block((15,), dense=True)
    ch = bernoulli(Fraction(1, 2))
    full = Budget(max_steps=2_000_000)
    res = compute_sigma(block, [ch, ch], full)
    truth = _true_power(res, [ch, ch], block.base_period)
    brackets = _brackets(block, [ch, ch], full.steps)
    assert brackets, "the cut points fall inside the search"
    for b in brackets:
        assert b.lower <= truth <= b.upper
        assert b.lower_exact, "the block has an exact rank oracle"
    assert brackets[-1].lower == truth, "late in the search the front already holds the worst set"


def _three_sensor_body() -> str:
    A = block_diagonal(cyclotomic_companion(21))
    rng = np.random.default_rng(21)
    rows = rng.integers(-3, 4, size=(3, len(A))).tolist()
    return json.dumps(
        {
            "system": {"A": A, "C": rows, "sensors": [{"name": f"s{k}", "rows": [k]} for k in range(3)]},
            "channel": {
                "model": "per_sensor",
                "channels": {f"s{k}": {"model": "bernoulli", "arrival_probability": "1/2"} for k in range(3)},
            },
        }
    )


def test_analyze_cut_short_reports_the_bracket_in_json_problem_and_text() -> None:
    request = load_request(_three_sensor_body())
    with pytest.raises(BudgetExceeded) as info:
        analyze(request, budget=Budget(max_steps=3000))
    partial = info.value.partial
    assert partial is not None
    b = partial["sigma_bracket"]
    lo, hi = b["sigma_lower"], b["sigma_upper"]
    assert 0 < lo["sigma"] <= hi["sigma"] <= 1
    assert b["phases"] == 21 and b["modulus"] == 2.0
    # The ends are sigma^21 = prod (1/2)^z exactly.
    assert lo["sigma"] == pytest.approx(0.5 ** (sum(lo["miss_counts"]) / 21), rel=1e-12)
    assert hi["sigma"] == pytest.approx(0.5 ** (sum(hi["miss_counts_at_least"]) / 21), rel=1e-12)
    (block,) = [blk for blk in fmo_blocks(request.system) if blk.phase is not None]
    space = SlotSpace.from_block(block.phase)
    assert rank(space, space.mask([tuple(s) for s in lo["blind_set"]])) < space.n_columns
    assert "confirmed in exact arithmetic" in lo["proof"]
    rate_lo, rate_hi = 4 * lo["sigma"], 4 * hi["sigma"]
    expected = "unstable" if rate_lo > 1 else ("this block is stable" if rate_hi < 1 else "undecided")
    assert b["implies"].startswith(expected)
    doc = problem_from_exception(info.value).to_dict()
    assert doc["status"] == 504 and doc["sigma_bracket"] == b
    json.dumps(doc)  # JSON-ready
    text = partial_summary(partial)
    assert lo["sigma_exact"] in text and hi["sigma_exact"] in text


def test_budget_outside_the_search_has_no_bracket() -> None:
    body = json.loads(_three_sensor_body())
    body["channel"] = {"model": "bernoulli", "arrival_probability": "1/2"}
    body["system"].pop("sensors")
    with pytest.raises(BudgetExceeded) as info:
        analyze(load_request(json.dumps(body)), budget=Budget(max_steps=1))
    assert info.value.partial is None
    assert "sigma_bracket" not in problem_from_exception(info.value).to_dict()
