"""``kfio bounds --grid``: the bounds' region map carries kfio's exact labels."""

from __future__ import annotations

from pathlib import Path

from kfio import load_request
from kfio.riccati_bounds import compute_bounds

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_bounds_grid_has_exact_labels_consistent_with_the_bounds():
    req = load_request((EXAMPLES / "regions_seed000_diagonal.json").read_text())
    region = compute_bounds(req, flags={"grid": 6}).to_dict()["region"]
    exact = region["exact"]
    assert exact["basis"] == "extension" and exact["values"] == region["values"]
    decided = 0
    for row_b, row_e in zip(region["labels"], exact["labels"]):
        for b, e in zip(row_b, row_e):
            if b == "stable":
                assert e == "stable"
            elif b == "unstable":
                assert e in ("unstable", "boundary")
            decided += b != "undecided"
    assert decided < 36 and all(e in ("stable", "unstable", "boundary") for r in exact["labels"] for e in r)
    # Liu and Goldsmith (2004) Sec. VI-B: exactly stable iff lambda_1 > 21/25 and lambda_2 > 5/9
    assert exact["boundary"]["envelope"]["lambda_1_min_exact"] == "21/25"
