"""The simulation plot draws what the report says: the predictor and, beside it, the filtered P(t|t)."""

from __future__ import annotations

import json

import numpy as np

from kfio import Budget, load_request
from kfio.service.api.schemas import REQUEST_EXAMPLES
from kfio.service.plots import simulation, simulation_figure
from kfio.simulation._simulate import simulate

PNG = b"\x89PNG\r\n\x1a\n"


def _request():
    body = json.loads(json.dumps(REQUEST_EXAMPLES["seed004-3x3"]["value"]))
    body["options"] = {"simulate": {"steps": 40, "trajectories": 300, "seed": 7}}
    return load_request(json.dumps(body))


def _line(fig, label: str) -> np.ndarray:
    (ax,) = fig.axes
    lines = [ln for ln in ax.get_lines() if ln.get_label() == label]
    assert len(lines) == 1, [ln.get_label() for ln in ax.get_lines()]
    return np.asarray(lines[0].get_ydata(), dtype=float)


def test_filtered_mean_and_median_are_drawn_from_the_report() -> None:
    request = _request()
    report = simulate(request, budget=Budget(seconds=120)).to_dict()
    fig = simulation_figure(report, request)
    filtered, predictor = report["filtered"], report["mean_trace"]
    np.testing.assert_array_equal(_line(fig, "filtered P(t|t): sample mean"), filtered["mean_trace"])
    np.testing.assert_array_equal(_line(fig, "filtered P(t|t): median"), filtered["percentiles"]["50"])
    np.testing.assert_array_equal(_line(fig, "sample mean"), predictor)
    # the measurement update only removes uncertainty: the filtered mean lies below the predictor's
    assert (np.asarray(filtered["mean_trace"]) <= np.asarray(predictor) * (1 + 1e-12)).all()


def test_simulation_plot_is_a_png() -> None:
    assert simulation(_request(), Budget(seconds=120), {}).startswith(PNG)
