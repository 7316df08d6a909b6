"""Published JSON Schemas (draft 2020-12) of kfio's files, written from the code.

One self-contained document per file kind, each the component schema the
OpenAPI document uses (:data:`kfio.service.api.schemas.COMPONENTS`, the sweep
schema of ``POST /v1/sweeps``) with every component it refers to under
``$defs``; the check file's schema is built from :mod:`kfio.check`'s own
lists of keys.  They are shipped in the package (``kfio/service/schemas/``)
and served at ``GET /schemas/{name}.json``.  JSON Schema cannot say
everything the validator checks (``Q`` symmetric and semidefinite, a Markov
channel's histories complete, ...): what it cannot say is in ``description``,
and the validator answers with the field and the rule.

Usage::

    python -m kfio.service.schema_files            # write service/schemas/*.json
    python -m kfio.service.schema_files --check    # exit 1 if a written file is stale
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
from pathlib import Path
from typing import Any, Sequence

from kfio.model import MAX_CHECK_ENTRIES, MAX_RUN_BUDGET_S

DIALECT = "https://json-schema.org/draft/2020-12/schema"
PACKAGE_DIR = Path(__file__).resolve().parent / "schemas"

_COMPONENT_REF = "#/components/schemas/"


def _check_components() -> dict[str, dict[str, Any]]:
    """The check file, and the plant and channel files it names (see docs/check.md)."""
    from kfio.check import CHECK_ENTRY_KEYS, CHECK_OPTION_KEYS, CHECK_TOP_KEYS, COMMAND_OF, OUTAGE_KEYS, VERDICTS

    from .api.schemas import exact_number

    requirements: dict[str, Any] = {
        "verdict": {"enum": list(VERDICTS), "description": "the exact verdict the entry must have"},
        "margin": exact_number(
            "m in [0, 1): the worst rate max_k |alpha_k|^2 sigma_k must be at most 1 - m", minimum=0, exclusiveMaximum=1
        ),
        "critical_arrival_probability_at_most": exact_number(
            "the exact critical arrival probability must be at most this (one Bernoulli packet)", minimum=0, maximum=1
        ),
        "tail_exponent_above": exact_number(
            "the tail exponent kappa must exceed this (2: finite variance)", exclusiveMinimum=0
        ),
        "trace_V_bar_at_most": exact_number(
            "trace(V_bar), the certified upper bound of lim E[P], must be at most this (needs Q and R)",
            exclusiveMinimum=0,
        ),
        "loop_verdict": {"enum": list(VERDICTS), "description": "the exact mean-square verdict the loop must have"},
        "loop_cost_at_most": exact_number(
            "the loop's exact stationary cost lim E[x'Wx + a'Ua] must be at most this", exclusiveMinimum=0
        ),
        "critical_sensor_arrival_probability_at_most": exact_number(
            "the loop's exact critical sensor arrival probability must be at most this", minimum=0, maximum=1
        ),
        "critical_actuator_arrival_probability_at_most": exact_number(
            "the loop's exact critical actuator arrival probability must be at most this", minimum=0, maximum=1
        ),
        "outage": {
            "type": "object",
            "description": "the upper end of the Wilson 95% interval of the stationary P(trace P > threshold) must "
            "be at most epsilon (Monte Carlo evidence; needs Q and R); steps * trajectories is capped by the "
            "simulation limits",
            "properties": {
                "threshold": exact_number("M > 0", exclusiveMinimum=0),
                "epsilon": exact_number("epsilon in (0, 1)", exclusiveMinimum=0, exclusiveMaximum=1),
                "trajectories": {"type": "integer", "minimum": 2},
                "steps": {"type": "integer", "minimum": 1},
                "seed": {"type": "integer", "minimum": 0},
            },
            "required": ["threshold", "epsilon"],
            "additionalProperties": False,
        },
    }
    assert set(requirements) == set(COMMAND_OF) and set(requirements["outage"]["properties"]) == set(OUTAGE_KEYS)
    budget = exact_number(f"seconds, in (0, {MAX_RUN_BUDGET_S}]", exclusiveMinimum=0, maximum=MAX_RUN_BUDGET_S)
    entry: dict[str, Any] = {
        "type": "object",
        "description": "One plant and channel and the requirements on them, or one loop request file and the "
        "loop requirements on it.",
        "properties": {
            "name": {"type": "string", "minLength": 1, "description": "unique label (default: the two paths)"},
            "description": {"type": "string"},
            "plant": {"type": "string", "minLength": 1, "description": "plant file, relative to the check file"},
            "channel": {
                "type": "string",
                "minLength": 1,
                "description": "channel file, relative to the check file "
                "(default: the channel of the plant file, if it is a whole request)",
            },
            "trace": {
                "type": "string",
                "minLength": 1,
                "description": "a measured packet trace (one 0/1 per line), relative to the check file, instead of "
                "a channel: the channel fitted to it (kfio fit), verdict judged for the whole confidence region",
            },
            "level": {
                **exact_number("with trace: the joint confidence level, in (0, 1) (default 0.95)"),
            },
            "loop": {
                "type": "string",
                "minLength": 1,
                "description": "loop request file (kfio loop FILE), relative to the check file; instead of plant "
                "and channel, with the loop requirements",
            },
            "options": {**schema_ref("Options"), "description": "the request's options"},
            "requirements": {
                "type": "object",
                "minProperties": 1,
                "properties": requirements,
                "additionalProperties": False,
            },
        },
        "required": ["requirements"],
        "oneOf": [{"required": ["plant"]}, {"required": ["loop"]}],
        "additionalProperties": False,
    }
    assert set(entry["properties"]) == CHECK_ENTRY_KEYS
    check: dict[str, Any] = {
        "type": "object",
        "description": "A kfio check file (kfio check FILE; docs/check.md). The validator also reads each plant "
        "and channel file as a request and names the field of any mistake.",
        "properties": {
            "$schema": {"type": "string"},
            "description": {"type": "string"},
            "options": {
                "type": "object",
                "properties": {"time_budget_s": budget, "point_budget_s": budget},
                "additionalProperties": False,
            },
            "checks": {
                "type": "array",
                "minItems": 1,
                "maxItems": MAX_CHECK_ENTRIES,
                "items": schema_ref("CheckEntry"),
            },
        },
        "required": ["checks"],
        "additionalProperties": False,
    }
    assert (
        set(check["properties"]) == CHECK_TOP_KEYS
        and set(check["properties"]["options"]["properties"]) == CHECK_OPTION_KEYS
    )
    plant = {
        "description": 'A plant file of a check: {"system": ...} (a whole request is fine) or the bare system.',
        "anyOf": [
            {
                "type": "object",
                "properties": {
                    "system": schema_ref("System"),
                    "channel": schema_ref("Channel"),
                    "options": schema_ref("Options"),
                },
                "required": ["system"],
                "additionalProperties": False,
            },
            schema_ref("System"),
        ],
    }
    channel = {
        "description": 'A channel file of a check: {"channel": ...} or the bare channel.',
        "anyOf": [
            {
                "type": "object",
                "properties": {"channel": schema_ref("Channel")},
                "required": ["channel"],
                "additionalProperties": False,
            },
            schema_ref("Channel"),
        ],
    }
    outcome = {
        "type": "object",
        "properties": {
            "entry": {"type": "string"},
            "requirement": {"enum": sorted(COMMAND_OF)},
            "status": {"enum": ["pass", "fail", "error"]},
            "measured": {"type": "string"},
            "required": {"type": "string"},
            "detail": {"type": "string"},
            "seconds": {"type": "number", "minimum": 0},
            "error_kind": {"type": ["string", "null"]},
        },
        "required": ["entry", "requirement", "status", "measured", "required", "detail", "seconds", "error_kind"],
        "additionalProperties": False,
    }
    report = {
        "type": "object",
        "description": "The JSON of kfio check --json.",
        "properties": {
            "kfio_version": {"type": "string"},
            "command": {"const": "check"},
            "source": {"type": "string"},
            "status": {"enum": ["pass", "fail", "budget"]},
            "requirements": {"type": "integer", "minimum": 0},
            "passed": {"type": "integer", "minimum": 0},
            "failed": {"type": "integer", "minimum": 0},
            "errors": {"type": "integer", "minimum": 0},
            "seconds": {"type": "number", "minimum": 0},
            "workers": {"type": "integer", "minimum": 1},
            "outcomes": {"type": "array", "items": outcome},
        },
        "required": ["kfio_version", "command", "status", "requirements", "passed", "failed", "errors", "outcomes"],
        "additionalProperties": False,
    }
    return {"CheckEntry": entry, "CheckFile": check, "PlantFile": plant, "ChannelFile": channel, "CheckReport": report}


def schema_ref(name: str) -> dict[str, str]:
    return {"$ref": _COMPONENT_REF + name}


def _all_components() -> dict[str, dict[str, Any]]:
    # imported here, not at the top: the API package serves these files and imports this module's table
    from .api.fit import FIT_COMPONENTS
    from .api.loop_schemas import LOOP_COMPONENTS
    from .api.schemas import COMPONENTS
    from .api.sweeps import SWEEP_SCHEMA

    return {**COMPONENTS, **LOOP_COMPONENTS, **FIT_COMPONENTS, "Sweep": SWEEP_SCHEMA, **_check_components()}


#: File name (without .json) -> (component, title).
DOCUMENTS: dict[str, tuple[str, str]] = {
    "request": ("AnalysisRequest", "kfio request (kfio analyze|bounds|simulate FILE, POST /v1/analyze ...)"),
    "analyze-report": ("StabilityReport", "kfio analyze --json report"),
    "bounds-report": ("BoundsReport", "kfio bounds --json report"),
    "simulate-report": ("SimulationReport", "kfio simulate --json report"),
    "sweep": ("Sweep", "kfio sweep file (kfio sweep FILE, POST /v1/sweeps)"),
    "check": ("CheckFile", "kfio check file (kfio check FILE)"),
    "check-report": ("CheckReport", "kfio check --json report"),
    "plant": ("PlantFile", "plant file of a kfio check file"),
    "channel": ("ChannelFile", "channel file of a kfio check file"),
    "loop": ("LoopRequest", "kfio loop request (kfio loop FILE, POST /v1/loop)"),
    "loop-report": ("LoopReport", "kfio loop --json report"),
    "fit": ("FitRequest", "kfio fit request (POST /v1/fit)"),
    "fit-report": ("FitReport", "kfio fit --json report"),
}


def _refs(node: Any) -> set[str]:
    if isinstance(node, dict):
        found = {node["$ref"][len(_COMPONENT_REF) :]} if str(node.get("$ref", "")).startswith(_COMPONENT_REF) else set()
        for value in node.values():
            found |= _refs(value)
        return found
    if isinstance(node, list):
        return set().union(*(_refs(v) for v in node)) if node else set()
    return set()


def _rewrite(node: Any) -> Any:
    if isinstance(node, dict):
        return {
            k: ("#/$defs/" + v[len(_COMPONENT_REF) :] if k == "$ref" and v.startswith(_COMPONENT_REF) else _rewrite(v))
            for k, v in node.items()
        }
    if isinstance(node, list):
        return [_rewrite(v) for v in node]
    return node


def document(name: str) -> dict[str, Any]:
    """The schema ``name`` (a key of :data:`DOCUMENTS`) as a self-contained 2020-12 document."""
    components = _all_components()
    root, title = DOCUMENTS[name]
    needed, todo = set(), [root]
    while todo:
        for ref in _refs(components[todo.pop()]):
            if ref not in needed:
                needed.add(ref)
                todo.append(ref)
    doc: dict[str, Any] = {"$schema": DIALECT, "$id": f"urn:kfio:schema:{name}", "title": title}
    doc.update(_rewrite(copy.deepcopy(components[root])))
    defs = {k: _rewrite(copy.deepcopy(components[k])) for k in sorted(needed - {root})}
    if root in needed:  # a recursive root refers to itself through $defs too
        defs[root] = _rewrite(copy.deepcopy(components[root]))
    if defs:
        doc["$defs"] = defs
    return doc


def texts() -> dict[str, str]:
    """File name -> stable JSON text of every published schema."""
    return {f"{name}.json": json.dumps(document(name), indent=2, ensure_ascii=False) + "\n" for name in DOCUMENTS}


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m kfio.service.schema_files", description=__doc__.splitlines()[0])
    parser.add_argument("--output", type=Path, default=PACKAGE_DIR, help=f"folder to write (default {PACKAGE_DIR})")
    parser.add_argument("--check", action="store_true", help="do not write; exit 1 if a file differs or is missing")
    args = parser.parse_args(argv)
    wanted = texts()
    if args.check:
        stale = [n for n, t in wanted.items() if not (args.output / n).is_file() or (args.output / n).read_text() != t]
        extra = sorted(p.name for p in args.output.glob("*.json") if p.name not in wanted)
        for name in stale + extra:
            print(f"{args.output / name} is stale; run: python -m kfio.service.schema_files", file=sys.stderr)
        return 1 if stale or extra else 0
    args.output.mkdir(parents=True, exist_ok=True)
    for name, text in wanted.items():
        (args.output / name).write_text(text, encoding="utf-8")
    print(f"wrote {len(wanted)} schemas to {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
