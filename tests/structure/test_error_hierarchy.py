"""Every error the library raises is in its hierarchy.

``ValueError`` and ``ArithmeticError`` escaped from the eigenstructure, the
algebraic comparisons, the rate decision, the Riccati/``P_hat`` helpers and the
region constraints, and came out of the CLI as exit 70 (internal error).  (The
eigenstructure and algebraic comparisons are tested with the certified root
finder that replaces them.)  The
FMO step caught *every* exception as "number field too large", hiding bugs.
"""

from __future__ import annotations

import json
from fractions import Fraction as F

import numpy as np
import pytest

from kfio import load_request
from kfio.design._regions_constraints import block_constraints
from kfio.errors import AnalyzerError, InvalidInput, NumericalFailure
from kfio.riccati_bounds._phat import BatchedMare, p_hat
from kfio.service.cli import main
from kfio.sigma._decide import bernoulli_factor
from kfio.structure import _fmo
from kfio.structure._fmo import fmo_blocks

ONE = np.eye(1)


def test_p_hat_horizon_below_one_is_invalid_input() -> None:
    with pytest.raises(InvalidInput, match="N must be at least 1"):
        p_hat(2 * ONE, ONE, ONE, ONE, 0.9, 0)
    with pytest.raises(InvalidInput, match="N must be at least 1"):
        BatchedMare(2 * ONE, ONE, ONE, ONE, 0.9).g_n(np.ones(1), 0)


def test_misaligned_sigma_is_invalid_input() -> None:
    system = load_request(
        json.dumps({"system": {"A": [[2]], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": 0.9}})
    ).system
    with pytest.raises(InvalidInput, match="aligned with the FMO blocks"):
        block_constraints(system, sigma=[])


def test_non_integer_blind_count_is_a_numerical_failure() -> None:
    with pytest.raises(NumericalFailure, match="non-integer blind count"):
        bernoulli_factor([F(1, 3)], [F(1, 2)], 2)


# Eigenvalues +-sqrt(2): the class's field Q(sqrt(2)) is built by SymPy (a rational modulus
# with roots of unity, such as a rotation, takes the FLINT route over Q(zeta_L) instead).
ROTATION = load_request(
    json.dumps(
        {
            "system": {"A": [[0, 2], [1, 0]], "C": [[1, 0]]},
            "channel": {"model": "bernoulli", "arrival_probability": 0.9},
        }
    )
).system


def test_fmo_records_only_expected_sympy_failures(monkeypatch: pytest.MonkeyPatch) -> None:
    def fails(*args, **kwargs):
        raise NotImplementedError("SymPy cannot build this compositum")

    monkeypatch.setattr(_fmo, "_member_field_and_values", fails)
    (block,) = fmo_blocks(ROTATION)
    assert block.phase.exact_rank is None
    assert any("numerical" in note for note in block.notes)


def test_fmo_lets_real_bugs_propagate(monkeypatch: pytest.MonkeyPatch) -> None:
    def bug(*args, **kwargs):
        raise KeyError("a bug, not a large number field")

    monkeypatch.setattr(_fmo, "_member_field_and_values", bug)
    with pytest.raises(KeyError):
        fmo_blocks(ROTATION)


def test_cli_maps_numerical_failure_to_exit_5(monkeypatch, tmp_path, capsys) -> None:
    import kfio

    def fails(*args, **kwargs):
        raise NumericalFailure("could not separate an algebraic number from a rational")

    monkeypatch.setattr(kfio, "analyze", fails)  # the CLI looks it up when it runs
    path = tmp_path / "r.json"
    path.write_text(
        json.dumps({"system": {"A": [[2]], "C": [[1]]}, "channel": {"model": "bernoulli", "arrival_probability": 0.9}})
    )
    assert main(["analyze", str(path)]) == 5
    err = capsys.readouterr().err
    assert "numerical failure" in err and "Traceback" not in err


def test_hierarchy_subclasses_builtins() -> None:
    assert issubclass(NumericalFailure, ArithmeticError) and issubclass(NumericalFailure, AnalyzerError)
    assert issubclass(InvalidInput, ValueError)
