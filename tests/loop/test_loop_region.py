"""The two-link stable region: exact boundary points, checked by closed forms and by exact verdicts beside them."""

from __future__ import annotations

import json
from fractions import Fraction as F
from pathlib import Path

from kfio.loop import analyze_loop, parse_loop_request
from kfio.loop._mjls import loop_mjls
from kfio.loop._region import _bernoulli
from kfio.loop._verdict import decide

ROOT = Path(__file__).resolve().parents[2]


def _body(protocol: str, points: int) -> dict:
    body = json.loads((ROOT / "examples" / "loop_scalar.json").read_text())
    body["options"]["loop"].update(protocol=protocol, region=points)
    return body


def test_tcp_scalar_region_is_the_rectangle_of_the_closed_forms():
    # e-block: lam (a - k)^2 + (1 - lam) a^2 < 1 iff lam > 9/16; x-block: nu > 75/152 (a = 5/4, k = 1/2, L = 3/5)
    rows = analyze_loop(parse_loop_request(_body("tcp", 6))).region.boundary
    assert [row.sensor for row in rows] == [F(2 * i + 1, 12) for i in range(6)]
    for row in rows:
        assert row.critical_actuator_arrival_probability_exact == ("75/152" if row.sensor > F(9, 16) else None)


def test_udp_boundary_points_separate_exact_verdicts():
    req = parse_loop_request(_body("udp", 3))
    rows = analyze_loop(req).to_dict()["region"]["boundary"]
    found = [r for r in rows if r["critical_actuator_arrival_probability"] is not None]
    assert found
    for row in found:
        lam = F(row["sensor_arrival_probability_exact"])
        nu = row["critical_actuator_arrival_probability"]
        for delta, verdict in ((1e-6, "stable"), (-1e-6, "unstable")):
            x = F(str(round(nu + delta, 9)))
            sys = loop_mjls(req, {"/channel": _bernoulli(lam), "/actuator_channel": _bernoulli(x)})
            assert decide(sys).verdict == verdict
