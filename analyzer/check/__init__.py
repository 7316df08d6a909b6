"""Requirements as code: ``kfio check FILE`` judges plants and channels against stated requirements.

A check file (JSON or TOML) lists entries, each a plant file and a channel
file (paths relative to the check file) and requirements on them: the exact
verdict, a margin on the worst rate, the critical arrival probability, a
certified bound on ``trace(V_bar)``, the tail exponent, a stationary outage
probability (:mod:`kfio.check._requirements` gives the maths and papers).
Every requirement is judged on the JSON report of ``kfio analyze``,
``bounds`` or ``simulate`` for that entry, the runs in parallel.

Examples
--------
>>> from kfio.check import parse_check, run_check
>>> import json, pathlib, tempfile
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> _ = (d / "plant.json").write_text(json.dumps({"system": {"A": [[-1.25]], "C": [[1]]}}))
>>> _ = (d / "radio.json").write_text(json.dumps({"model": "bernoulli", "arrival_probability": "1/2"}))
>>> spec = parse_check({"checks": [{"name": "scalar", "plant": "plant.json", "channel": "radio.json",
...     "requirements": {"verdict": "stable", "critical_arrival_probability_at_most": "2/5"}}]}, d)
>>> [(o.requirement, o.status, o.measured) for o in run_check(spec, workers=1).outcomes]
[('verdict', 'pass', 'stable'), ('critical_arrival_probability_at_most', 'pass', '9/25')]

``kfio.check`` (the attribute of the package ``kfio``) is the typed function
:func:`check`; this subpackage stays importable under the same name
(``from kfio.check import run_check``).  Its names load on first use, so
importing it costs nothing until then: ``kfio`` imports it at start-up to
keep the function, not the subpackage, as its attribute.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_names

#: Public name -> the private module (relative to this package) that defines it.
_LAZY = {
    "check": "._api",
    "CHECK_ENTRY_KEYS": "._spec",
    "CHECK_OPTION_KEYS": "._spec",
    "CHECK_TOP_KEYS": "._spec",
    "CheckEntry": "._spec",
    "CheckResult": "._run",
    "CheckSpec": "._spec",
    "COMMAND_OF": "._requirements",
    "ERROR_KINDS": "._run",
    "judge": "._requirements",
    "Judgement": "._requirements",
    "load_check": "._spec",
    "load_tree": "._spec",
    "OUTAGE_KEYS": "._requirements",
    "Outcome": "._run",
    "parse_check": "._spec",
    "parse_requirements": "._requirements",
    "Requirement": "._requirements",
    "run_check": "._run",
    "run_one": "._run",
    "VERDICTS": "._requirements",
}

if TYPE_CHECKING:
    from ._api import check
    from ._requirements import COMMAND_OF, OUTAGE_KEYS, VERDICTS, Judgement, Requirement, judge, parse_requirements
    from ._run import ERROR_KINDS, CheckResult, Outcome, run_check, run_one
    from ._spec import (
        CHECK_ENTRY_KEYS,
        CHECK_OPTION_KEYS,
        CHECK_TOP_KEYS,
        CheckEntry,
        CheckSpec,
        load_check,
        load_tree,
        parse_check,
    )


__getattr__, __dir__ = lazy_names(__name__, _LAZY, globals())


__all__ = [
    "CHECK_ENTRY_KEYS",
    "CHECK_OPTION_KEYS",
    "CHECK_TOP_KEYS",
    "COMMAND_OF",
    "CheckEntry",
    "CheckResult",
    "CheckSpec",
    "ERROR_KINDS",
    "Judgement",
    "OUTAGE_KEYS",
    "Outcome",
    "Requirement",
    "VERDICTS",
    "check",
    "judge",
    "load_check",
    "load_tree",
    "parse_check",
    "parse_requirements",
    "run_check",
    "run_one",
]
