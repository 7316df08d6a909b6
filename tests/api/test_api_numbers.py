"""Floats through the Python API: the JSON route's number, and a text that reads back to the same float."""

from __future__ import annotations

import json
from fractions import Fraction

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from kfio import load_json, parse_number
from kfio.model._coerce import python_leaf, python_tree

finite64 = st.floats(allow_nan=False, allow_infinity=False, width=64)
finite32 = st.floats(allow_nan=False, allow_infinity=False, width=32)


def exact(x) -> Fraction:
    return parse_number(python_leaf(x), "/x", max_digits=400)


@settings(max_examples=300, deadline=None)
@given(finite64)
def test_a_float64_is_the_number_json_text_denotes(x):
    via_json = parse_number(load_json(json.dumps([x]))[0], "/x", max_digits=400)
    assert exact(x) == exact(np.float64(x)) == via_json
    assert float(exact(x)) == x  # the shortest text reads back to the same double


@settings(max_examples=300, deadline=None)
@given(finite32)
def test_a_float32_means_its_own_shortest_text(x):
    f = np.float32(x)
    value = exact(f)
    assert np.float32(float(value)) == f  # reads back to the same float32
    # and it has no more significant digits than the double's text of the same value
    # (float32(0.1): "0.1", not "0.10000000149011612"; float32(1e12): "1e12", not "999999995904")
    assert _significant(np.format_float_scientific(f, unique=True)) <= _significant(
        np.format_float_scientific(float(f), unique=True)
    )


def _significant(text: str) -> int:
    """Significant digits of a scientific-notation text (``"9.99e+11"`` -> 3)."""
    return max(1, len(text.split("e")[0].replace("-", "").replace(".", "").rstrip("0").lstrip("0")))


@settings(max_examples=100, deadline=None)
@given(st.lists(st.lists(finite64, min_size=2, max_size=2), min_size=1, max_size=3))
def test_arrays_and_lists_give_the_same_tree(rows):
    assert python_tree(np.array(rows)) == python_tree(rows) == python_tree(tuple(map(tuple, rows)))
