"""Which view builds the JSON of which report class: one table, resolved lazily.

Keys are class paths inside the ``kfio`` package, values ``"module:function"``
inside :mod:`kfio._json`.  A view module is imported the first time one of
its classes is encoded, so ``kfio analyze`` never imports the views of
``bounds`` or ``simulate`` (nor what they would drag in).
"""

from __future__ import annotations

import importlib
from typing import Any, Callable

#: Report class (module path below ``kfio``, then qualname) -> ``"view module:function"``.
VIEWS: dict[str, str] = {
    # kfio analyze (Rohr, Marelli and Fu 2014, Theorem 1, and its extensions)
    "stability._verdict.StabilityReport": "_stability:stability_report",
    "stability._verdict.BlockReport": "_stability:block_report",
    "design._tail.TailReport": "_stability:tail_report",
    "design._tail.BlockTail": "_stability:block_tail",
    "design._ge_region.GeRegion": "_stability:ge_region",
    "design._ge_region.LineResult": "_stability:line_result",
    "design._ge_region.Crossing": "_stability:crossing",
    "design._ge_region.GeMap": "_stability:ge_map",
    "design._critical_parameter.CriticalParameter": "_stability:critical_parameter",
    "design._critical_parameter.ParameterConstraint": "_stability:constraint",
    "design._regions.SensorThresholds": "_regions:sensor_thresholds",
    "design._regions.RegionGrid": "_regions:region_grid",
    "design._regions_curve.BoundaryCurve": "_regions:boundary_curve",
    "design._regions_curve.Envelope": "_regions:envelope",
    "design._regions_curve.Segment": "_regions:segment",
    "design._sensor_gain.SensorGains": "_regions:sensor_gains",
    # kfio bounds (Sinopoli et al. 2004; Liu and Goldsmith 2004; Rohr, Marelli and Fu 2010)
    "riccati_bounds._report.BoundsReport": "_bounds:bounds_report",
    "riccati_bounds._report.CriticalInterval": "_bounds:critical_interval",
    "riccati_bounds._report.CovarianceBounds": "_bounds:covariance_bounds",
    "riccati_bounds._report.PHatBounds": "_bounds:p_hat_bounds",
    "riccati_bounds._report.RegionMap": "_bounds:region_map",
    "riccati_bounds._filtered.FilteredBounds": "_bounds:filtered_bounds",
    "riccati_bounds._targets.TraceTarget": "_bounds:trace_target",
    "riccati_bounds._certificate.StabilityCertificate": "_bounds:certificate",
    # kfio simulate
    "simulation._simulate.SimulationReport": "_simulation:simulation_report",
    "simulation._finite_horizon.FiniteHorizonReport": "_simulation:finite_horizon_report",
    "simulation._stationary.StationaryReport": "_simulation:stationary_report",
    "simulation._outage_target.OutageTarget": "_simulation:outage_target",
    # kfio loop (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007; Costa, Fragoso and Marques 2005)
    "loop._report.LoopReport": "_loop:loop_report",
    "loop._parts.EstimatorAlone": "_loop:estimator_alone",
    "loop._region.Region": "_loop:region",
    "loop._region.BoundaryPoint": "_loop:boundary_point",
    "loop._udp_bounds.UdpRegionBounds": "_loop:udp_region_bounds",
    "loop._udp_bounds.UdpOuterBound": "_loop:udp_outer_bound",
    "loop._lqg_types.LqgPart": "_loop:lqg_part",
    # kfio sweep
    "sweep._engine.SweepResult": "_sweep:sweep_result",
    "sweep._engine.SweepRow": "_sweep:sweep_row",
    # kfio fit (Clopper and Pearson 1934; Schwarz 1978) and the verdict at a stated confidence
    "fit._fit.FitReport": "_fit:fit_report",
    "fit._confidence.ConfidenceVerdict": "_fit:confidence_verdict",
    # kfio check
    "check._run.CheckResult": "_check:check_result",
    "check._run.Outcome": "_check:outcome",
}

_ROOT = __name__.split(".")[0]  # "kfio"
_resolved: dict[type, Callable[[Any], dict[str, Any]] | None] = {}


def class_key(cls: type) -> str:
    """``cls`` as a key of :data:`VIEWS`: its module path below ``kfio`` and its qualname."""
    module = cls.__module__
    inside = module.partition(".")[2] if module.split(".")[0] == _ROOT else module
    return f"{inside}.{cls.__qualname__}"


def view_of(cls: type) -> Callable[[Any], dict[str, Any]] | None:
    """The view function of ``cls`` (importing its module on first use), or ``None`` if it has none."""
    try:
        return _resolved[cls]
    except KeyError:
        pass
    target = VIEWS.get(class_key(cls))
    view = None
    if target is not None:
        module, _, function = target.partition(":")
        view = getattr(importlib.import_module(f"{__package__}.{module}"), function)
    _resolved[cls] = view
    return view


__all__ = ["VIEWS", "class_key", "view_of"]
