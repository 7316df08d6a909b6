"""Sensor names are drawn as plain text.

Reproducer: a sensor named ``$\\nosuchcmd$`` reached matplotlib's mathtext
parser through the region plot's axis labels (HTTP 500, ValueError); nested
braces raised RecursionError.
"""

from __future__ import annotations

import copy
import json

import pytest

from kfio import Budget, load_request
from kfio.service.api.schemas import REQUEST_EXAMPLES
from kfio.service.plots import region

PNG = b"\x89PNG\r\n\x1a\n"


def _with_names(first: str, second: str):
    body = copy.deepcopy(REQUEST_EXAMPLES["seed000-two-sensors"]["value"])
    old = [s["name"] for s in body["system"]["sensors"]]
    for s, name in zip(body["system"]["sensors"], (first, second)):
        s["name"] = name
    body["channel"]["channels"] = {new: body["channel"]["channels"][o] for o, new in zip(old, (first, second))}
    return load_request(json.dumps(body))


@pytest.mark.parametrize(
    "names",
    [
        ("$\\nosuchcmd$", "$x^{$"),
        ("$" + "{" * 31 + "}" * 31 + "$", "100% $$ \\ ^_"),
    ],
)
def test_region_plot_draws_sensor_names_as_plain_text(names: tuple[str, str]) -> None:
    png = region(_with_names(*names), Budget(seconds=120), {"points": 3})
    assert png.startswith(PNG)
