"""kfio: stability of Kalman filters whose measurements travel over lossy networks.

Knows nothing of HTTP or the command line (see :mod:`kfio.service`).  Exact in,
exact through, converted at the edge.

The Python API (see ``docs/python_api.md``)::

    import kfio
    sys = kfio.System(A=[[1.25, 0], [1, 1.1]], C=[[1, 1]], Q=[[20, 0], [0, 20]], R=[[2.5]])
    report = kfio.analyze(sys, kfio.bernoulli(0.5))      # the exact verdict
    kfio.bounds(sys, kfio.bernoulli(0.6))                 # Riccati and LMI bounds
    kfio.simulate(sys, kfio.bernoulli(0.6), steps=50)     # Monte Carlo
    kfio.expected_covariance(sys, kfio.bernoulli(0.6), 6) # exact E[P_t]
    kfio.fit("0110111011")                                # a channel model for a measured trace
    kfio.sweep("sweep.json"), kfio.check("kfio-check.toml")  # the files of ``kfio sweep`` and ``kfio check``

Typed (``py.typed``): ``report.verdict`` is a :class:`Verdict` (equal to its
JSON text), ``report.exact_of("critical_arrival_probability")`` the exact value
as a ``Fraction`` (or an :class:`ExactReal`), and the arguments take
:data:`NumberLike` and :data:`MatrixLike` values.

Every name is imported when first used, so ``import kfio`` (and the ``kfio``
command) start at once: SymPy, CVXPY and Matplotlib load only with the
function that needs them.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from ._lazy import lazy_names
from ._version import __version__

#: Public name -> the module (relative to kfio) that defines it.
_LAZY = {
    # the Python API
    "System": "._system",
    "analyze": "._api",
    "bounds": "._api",
    "simulate": "._api",
    "expected_covariance": "._api",
    "loop": ".loop._api",
    "fit": ".fit._fit",
    "FitReport": ".fit._fit",
    "sweep": ".sweep._api",
    "SweepResult": ".sweep._engine",
    "check": ".check._api",
    "CheckResult": ".check._run",
    "build_request": "._api",
    "request_dict": "._api",
    "bernoulli": ".model._channels",
    "gilbert_elliott": ".model._channels",
    "markov": ".model._channels",
    "per_sensor": ".model._channels",
    # errors and budgets
    "AnalyzerError": ".errors",
    "AssumptionViolation": ".errors",
    "BudgetExceeded": ".errors",
    "InvalidInput": ".errors",
    "LimitExceeded": ".errors",
    "NumericalFailure": ".errors",
    "Budget": "._budget",
    # the JSON route and the model
    "load_json": ".model._exact",
    "parse_number": ".model._exact",
    "DEFAULT_LIMITS": ".model._limits",
    "Limits": ".model._limits",
    "load_request": ".model._request",
    "parse_request": ".model._request",
    "MarkovChannel": ".model._types",
    "PerSensorChannel": ".model._types",
    "Request": ".model._types",
    "Sensor": ".model._types",
    # reports and the request-level entry points
    "StabilityReport": ".stability._verdict",
    "BlockReport": ".stability._verdict",
    "BoundsReport": ".riccati_bounds",
    "SimulationReport": ".simulation",
    "FiniteHorizonReport": ".simulation",
    "SimulationLimits": ".simulation",
    "DEFAULT_SIMULATION_LIMITS": ".simulation",
    # typed use: the verdict enum, exact values as objects, the argument types
    "Verdict": "._verdicts",
    "ExactReal": "._exact_values",
    "exact_value": "._exact_values",
    "BudgetLike": "._typing",
    "ChannelLike": "._typing",
    "MatrixLike": "._typing",
    "NumberLike": "._typing",
    "SensorsLike": "._typing",
    "StateSpaceLike": "._typing",
}

if TYPE_CHECKING:  # what the lazy names are, for type checkers and editors
    from ._api import analyze, bounds, build_request, expected_covariance, request_dict, simulate
    from ._budget import Budget
    from ._exact_values import ExactReal, exact_value
    from ._system import System
    from ._typing import BudgetLike, ChannelLike, MatrixLike, NumberLike, SensorsLike, StateSpaceLike
    from ._verdicts import Verdict
    from .check._api import check
    from .check._run import CheckResult
    from .errors import (
        AnalyzerError,
        AssumptionViolation,
        BudgetExceeded,
        InvalidInput,
        LimitExceeded,
        NumericalFailure,
    )
    from .fit._fit import FitReport, fit
    from .loop._api import loop
    from .model import (
        DEFAULT_LIMITS,
        Limits,
        MarkovChannel,
        PerSensorChannel,
        Request,
        Sensor,
        bernoulli,
        gilbert_elliott,
        load_json,
        load_request,
        markov,
        parse_number,
        parse_request,
        per_sensor,
    )
    from .riccati_bounds import BoundsReport
    from .simulation import DEFAULT_SIMULATION_LIMITS, FiniteHorizonReport, SimulationLimits, SimulationReport
    from .stability import BlockReport, StabilityReport
    from .sweep._api import sweep
    from .sweep._engine import SweepResult


__getattr__, __dir__ = lazy_names(__name__, _LAZY, globals())


# The import system binds a subpackage to its parent's attribute of the same name when it first loads
# it, which would make ``kfio.loop`` the subpackage after any ``from kfio.loop import ...``.  Loading the
# (lazy, import-free) subpackages now and unbinding them leaves the attributes to ``__getattr__``: the
# functions.  ``import kfio.loop._report as r`` therefore fails (its last step reads the attribute);
# ``from kfio.loop import _report`` reads the subpackage from ``sys.modules``.
for _name in ("loop", "fit", "sweep", "check"):
    importlib.import_module("." + _name, __name__)
    del globals()[_name]
del _name


__all__ = [
    "__version__",
    "AnalyzerError",
    "AssumptionViolation",
    "BlockReport",
    "BoundsReport",
    "Budget",
    "BudgetExceeded",
    "BudgetLike",
    "CheckResult",
    "ChannelLike",
    "DEFAULT_LIMITS",
    "DEFAULT_SIMULATION_LIMITS",
    "ExactReal",
    "FiniteHorizonReport",
    "FitReport",
    "InvalidInput",
    "LimitExceeded",
    "Limits",
    "MarkovChannel",
    "MatrixLike",
    "NumberLike",
    "NumericalFailure",
    "PerSensorChannel",
    "Request",
    "Sensor",
    "SensorsLike",
    "SimulationLimits",
    "SimulationReport",
    "StabilityReport",
    "StateSpaceLike",
    "SweepResult",
    "System",
    "Verdict",
    "analyze",
    "bernoulli",
    "bounds",
    "build_request",
    "check",
    "exact_value",
    "expected_covariance",
    "fit",
    "gilbert_elliott",
    "load_json",
    "loop",
    "load_request",
    "markov",
    "parse_number",
    "parse_request",
    "per_sensor",
    "request_dict",
    "simulate",
    "sweep",
]
