"""``options.bounds.sdp_cross_check``: the V_bar SDP is a cross-check, skipped above 12 states by default.

``V_bar`` comes from the MARE iteration (Sinopoli et al. (2004) Theorem 6(a), finished by
policy iteration), never from the SDP of Theorem 6(b): skipping the SDP must leave every
other field of the report unchanged.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from kfio import InvalidInput, load_request
from kfio.riccati_bounds import _options
from kfio.riccati_bounds._compute import compute_bounds
from kfio.riccati_bounds._options import parse_bounds_options

SYSTEM = {"A": [[1.25, 1], [0, 0.9]], "C": [[1, 0]], "Q": [[1, 0], [0, 1]], "R": [[2.5]]}


def request(**bounds):
    body = {"system": SYSTEM, "channel": {"model": "bernoulli", "arrival_probability": 0.6}}
    if bounds:
        body["options"] = {"bounds": bounds}
    return load_request(json.dumps(body))


def sdp_part(report) -> dict:
    return report.to_dict()["covariance"]["V_bar"]["sdp"]


@pytest.mark.parametrize("value", ["sometimes", "AUTO", "", 1, True, None, ["auto"], {"auto": 1}])
def test_bad_values_name_the_field_and_the_choices(value) -> None:
    with pytest.raises(InvalidInput, match="one of 'auto', 'always', 'never'") as err:
        parse_bounds_options(request(sdp_cross_check=value))
    assert err.value.field == "/options/bounds/sdp_cross_check"


def test_the_flag_wins_and_is_named() -> None:
    assert parse_bounds_options(request(sdp_cross_check="never"), {"sdp_cross_check": "always"}).sdp_cross_check == (
        "always"
    )
    with pytest.raises(InvalidInput, match="given as --sdp-cross-check"):
        parse_bounds_options(request(), {"sdp_cross_check": "maybe"})


@pytest.mark.parametrize("n,auto", [(1, True), (12, True), (13, False), (40, False)])
def test_auto_solves_up_to_twelve_states(n, auto) -> None:
    opts = parse_bounds_options(request())
    assert opts.sdp_cross_check == "auto" and opts.solve_sdp(n) is auto
    assert parse_bounds_options(request(sdp_cross_check="always")).solve_sdp(n)
    assert not parse_bounds_options(request(sdp_cross_check="never")).solve_sdp(n)


def test_skipping_changes_only_the_sdp_fields(monkeypatch) -> None:
    solved = compute_bounds(request())
    assert sdp_part(solved)["status"] == "optimal" and sdp_part(solved)["agrees"] is True
    monkeypatch.setattr(_options, "SDP_AUTO_MAX_N", 1)  # this 2-state request is now "large"
    skipped = compute_bounds(request())
    part = sdp_part(skipped)
    assert part["status"] == "skipped" and part["matrix"] is None and part["agrees"] is None
    assert "above 1 states" in part["reason"] and "sdp_cross_check to 'always'" in part["reason"]
    a, b = solved.to_dict(), skipped.to_dict()
    for d in (a, b):
        del d["covariance"]["V_bar"]["sdp"]
    assert a == b  # V_bar, its iteration and everything else do not come from the SDP
    forced = compute_bounds(request(sdp_cross_check="always"))
    assert sdp_part(forced)["status"] == "optimal"
    assert np.array_equal(np.array(sdp_part(forced)["matrix"]), np.array(sdp_part(solved)["matrix"]))


def test_never_says_so_in_the_report_and_the_summary() -> None:
    rep = compute_bounds(request(sdp_cross_check="never"))
    assert sdp_part(rep)["status"] == "skipped"
    assert "'never'" in sdp_part(rep)["reason"]
    assert "SDP: not solved" in rep.summary()
