"""The JSON contract of kfio._json: one encoder, one view per report class, nothing encoded by guess."""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import json
import math
import pkgutil
import subprocess
import sys
from fractions import Fraction

import numpy as np
import pytest
import sympy

import kfio
from kfio import analyze, load_request
from kfio._json import encode
from kfio._json._registry import VIEWS, class_key, view_of
from kfio._reporting import Report, ReportPart
from kfio.design._regions_constraints import BlindPattern
from kfio.riccati_bounds import compute_bounds
from kfio.simulation import simulate

from support.factories import bern, ge, make

SCALAR = {"A": [[-1.25]], "C": [[1]], "Q": [[1]], "R": [[2.5]]}
TWO = {
    "A": [[1.25, 0], [1, 1.1]],
    "C": [[1, 0], [1, 1]],
    "Q": [[20, 0], [0, 20]],
    "R": [[2.5, 0], [0, 2.5]],
    "sensors": [{"name": "first", "rows": [0]}, {"name": "second", "rows": [1]}],
}
PER_SENSOR = {"model": "per_sensor", "channels": {"first": bern(0.25), "second": bern(0.25)}}


def _kfio_classes() -> list[type]:
    names = ["kfio"] + [m.name for m in pkgutil.walk_packages(kfio.__path__, "kfio.")]
    out = []
    for name in names:
        module = importlib.import_module(name)
        out.extend(c for _, c in inspect.getmembers(module, inspect.isclass) if c.__module__ == name)
    return out


def test_every_report_class_has_a_view_and_every_view_a_class():
    classes = _kfio_classes()
    parts = [
        c for c in classes if issubclass(c, ReportPart) and c not in (ReportPart, Report, kfio._reporting.ShortRepr)
    ]
    assert len(parts) >= 25
    missing = [class_key(c) for c in parts if view_of(c) is None]
    assert missing == []
    assert {class_key(c) for c in parts} == set(VIEWS)  # no stale entry: each names a live class


def test_no_report_class_builds_its_own_dict():
    # the request's System.to_dict is the request form, not a report; ReportPart.to_dict is the encoder
    own = {class_key(c) for c in _kfio_classes() if "to_dict" in vars(c)}
    assert own == {"_reporting.ReportPart", "_system.System"}


def test_the_encoder_refuses_what_a_view_must_convert_and_names_the_path():
    with pytest.raises(TypeError, match=r"Fraction at \$\.a\[1\]\.b"):
        encode({"a": [1, {"b": Fraction(1, 2)}]})
    with pytest.raises(TypeError, match=r"Rational at \$\.x"):
        encode({"x": sympy.Rational(1, 3)})
    with pytest.raises(TypeError, match=r"object at \$\[0\]"):
        encode([object()])
    with pytest.raises(TypeError, match="keys must be str"):
        encode({1: "one"})
    # a pattern's misses are keyed by sensor name: only its parent's view can encode it
    with pytest.raises(TypeError, match=r"BlindPattern at \$"):
        encode(BlindPattern(((0, 0),), (0, 1)))


def test_an_exact_number_slipped_into_a_report_is_a_type_error_naming_the_field():
    rep = analyze(make(SCALAR, bern("1/2")))
    bad = dataclasses.replace(rep, critical_arrival_probability_exact=Fraction(9, 25))
    with pytest.raises(TypeError, match=r"Fraction at \$\.critical_arrival_probability_exact"):
        bad.to_dict()
    block = dataclasses.replace(rep.blocks[0], sigma_exact=sympy.sqrt(2))
    with pytest.raises(TypeError, match=r"at \$\.blocks\[0\]\.sigma_exact"):
        dataclasses.replace(rep, blocks=(block,)).to_json()


def test_nan_and_infinities_become_null_and_numpy_values_plain_json():
    assert encode([math.nan, math.inf, -math.inf, 0.5]) == [None, None, None, 0.5]
    assert encode(np.array([[1.0, np.nan], [np.inf, 2.0]])) == [[1.0, None], [None, 2.0]]
    assert encode(complex(math.inf, 1.0)) == [None, 1.0]
    out = encode({"i": np.int64(3), "b": np.bool_(True), "f": np.float32(0.5), "z": np.complex128(1 - 2j)})
    assert out == {"i": 3, "b": True, "f": 0.5, "z": [1.0, -2.0]}
    assert [type(v) for v in out.values()] == [int, bool, float, list]
    assert type(encode(np.float64(0.25))) is float
    # long double arrays too (tolist() keeps them as NumPy scalars, which json.dumps refuses)
    wide = encode({"x": np.array([1.5, np.inf], dtype=np.longdouble)})
    assert wide == {"x": [1.5, None]} and type(wide["x"][0]) is float
    json.dumps(wide, allow_nan=False)
    # through a report: an infinite rate is null in the JSON, and the text stays valid JSON
    rep = analyze(make(SCALAR, bern("1/2")))
    worse = dataclasses.replace(rep, blocks=(dataclasses.replace(rep.blocks[0], rate=math.inf, sigma=math.nan),))
    d = worse.to_dict()
    assert d["blocks"][0]["rate"] is None and d["blocks"][0]["sigma"] is None
    assert json.loads(worse.to_json())["blocks"][0]["rate"] is None


@pytest.mark.parametrize(
    "build",
    [
        lambda: analyze(make({"A": [[2, 0], [0, -2]], "C": [[1, 1]]}, ge("1/10", "3/10"))),
        lambda: analyze(make(TWO, PER_SENSOR)),
        lambda: compute_bounds(make(TWO, PER_SENSOR), flags={"grid": 4}),
        lambda: simulate(make(SCALAR, bern(0.5), {"steps": 8, "trajectories": 50, "seed": 1, "exact_steps": 3})),
    ],
    ids=["analyze-ge", "analyze-regions", "bounds-grid", "simulate-exact"],
)
def test_to_dict_is_a_plain_json_tree_with_the_version_first(build):
    rep = build()
    d = rep.to_dict()
    assert next(iter(d)) == "kfio_version" == next(iter(json.loads(rep.to_json())))
    assert json.loads(rep.to_json()) == d  # lists, str keys, finite floats: nothing the text changes


def test_a_report_nested_in_another_keeps_its_version_stamp():
    rep = simulate(make(SCALAR, bern(0.5), {"steps": 6, "trajectories": 40, "seed": 2, "exact_steps": 2}))
    exact = rep.to_dict()["exact"]
    assert list(exact)[0] == "kfio_version" and exact == rep.exact.to_dict()
    assert "kfio_version" not in rep.to_dict()["stationary"]  # a part of a report is not a report


def test_sub_objects_encode_to_the_same_fields_as_inside_their_report():
    rep = compute_bounds(make(TWO, PER_SENSOR), flags={"grid": 4})
    d = rep.to_dict()
    assert rep.region.to_dict() == d["region"] and rep.covariance.to_dict() == d["covariance"]
    assert d["region"]["exact"]["boundary"]["axes"] == ["first", "second"]
    assert d["sensors"][1]["critical_interval"] == rep.critical[1].to_dict()


def test_analyze_loads_only_the_analyze_views():
    code = (
        "import sys, kfio\n"
        "from kfio import load_request\n"
        'req = load_request(\'{"system": {"A": [[2]], "C": [[1]]}, '
        '"channel": {"model": "bernoulli", "arrival_probability": "1/2"}}\')\n'
        "assert not [m for m in sys.modules if m.startswith('kfio._json._')]\n"
        "kfio.analyze(req).to_json()\n"
        "print(sorted(m for m in sys.modules if m.startswith('kfio._json.')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    loaded = set(json.loads(out.stdout.strip().replace("'", '"')))
    assert "kfio._json._stability" in loaded
    assert not {"kfio._json._bounds", "kfio._json._simulation", "kfio._json._sweep", "kfio._json._regions"} & loaded


def test_per_sensor_blind_patterns_are_keyed_by_the_sensor_names():
    req = load_request(json.dumps({"system": {k: TWO[k] for k in ("A", "C", "sensors")}, "channel": PER_SENSOR}))
    regions = analyze(req).to_dict()["regions"]
    misses = [p["misses"] for b in regions["blocks"] for p in b["patterns"]]
    assert misses and all(list(m) == ["first", "second"] for m in misses)
    assert list(regions["sensor_improvement"]["binding_pattern"]["misses"]) == ["first", "second"]
    assert regions["boundary"]["pieces"] and all(
        set(p["misses"]) == {"first", "second"} for p in regions["boundary"]["pieces"]
    )
