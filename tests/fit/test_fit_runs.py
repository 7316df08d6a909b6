"""Run-length laws against closed forms and simulation, and the chi-square check."""

from __future__ import annotations

import numpy as np
import pytest

from kfio.fit import complete_runs, run_length_law, run_test

from support.traces import simulate_chain


def test_complete_runs_leave_out_the_cut_ones() -> None:
    a = np.array([0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 0, 0], dtype=np.uint8)
    assert complete_runs(a, 0).tolist() == [3, 1]  # the first (2) and last (2) runs are cut by the ends
    assert complete_runs(a, 1).tolist() == [1, 2, 1]


@pytest.mark.parametrize(("table", "stay"), [((0.7,), 0.3), ((0.25, 0.9), 0.75)])
def test_bernoulli_and_gilbert_elliott_loss_runs_are_geometric(table, stay) -> None:
    """P(L = l) = stay^(l-1) (1 - stay): 1 - lambda for Bernoulli, 1 - q for Gilbert-Elliott (Gilbert 1960)."""
    law = run_length_law(table, 0)
    ell = np.arange(1, 30)
    assert np.allclose(law[:29], stay ** (ell - 1) * (1 - stay), rtol=1e-12, atol=0)
    assert law.sum() == pytest.approx(1.0, abs=1e-12)


def test_gilbert_elliott_arrival_runs_are_geometric_in_the_failure_rate() -> None:
    law = run_length_law((0.25, 0.9), 1)
    ell = np.arange(1, 20)
    assert np.allclose(law[:19], 0.9 ** (ell - 1) * 0.1, rtol=1e-12)


def test_markov_order_2_loss_runs_match_simulation() -> None:
    """An order-2 chain: P(L = 1) = 1 - P(0 | 10), then P(0 | 00) per further step; checked by simulation too."""
    table = (0.3, 0.9, 0.6, 0.95)  # P(1 | 00), P(1 | 01), P(1 | 10), P(1 | 11)
    law = run_length_law(table, 0)
    assert law[0] == pytest.approx(0.6, abs=1e-12)  # a run starts with history "x1" then "10": ends w.p. P(1|10)
    assert law[1] == pytest.approx(0.4 * 0.3, abs=1e-12)
    assert law[2] == pytest.approx(0.4 * 0.7 * 0.3, abs=1e-12)
    runs = complete_runs(simulate_chain(table, 200_000, 9), 0)
    empirical = np.bincount(runs, minlength=6)[1:6] / runs.size
    assert np.allclose(empirical, law[:5], atol=0.01)


def test_chi_square_accepts_the_true_law_and_rejects_a_wrong_one() -> None:
    a = simulate_chain((0.3, 0.95), 50_000, 12)
    true = run_test(a, (0.3, 0.95), 0, 1)
    assert true.p_value is not None and true.p_value > 0.01
    assert sum(true.observed) == true.runs and sum(true.expected) == pytest.approx(true.runs)
    wrong = run_test(a, (0.6, 0.95), 0, 1)
    assert wrong.p_value is not None and wrong.p_value < 1e-6
    assert min(true.expected) >= 5


def test_too_few_runs_give_no_p_value() -> None:
    t = run_test(np.array([1, 0, 1, 1, 0, 1], dtype=np.uint8), (0.5,), 0, 1)
    assert t.runs == 2 and t.p_value is None and t.dof is None
