"""JSON Schemas of the HTTP contract, with examples from the seeds.

The routes read the raw body themselves (numbers must stay exact, so pydantic
never sees them); these schemas document what :func:`kfio.parse_request`
accepts.  The options and every size limit are rendered from the validator's
own table (:data:`kfio.model.OPTION_FIELDS`) and :data:`kfio.model.DEFAULT_LIMITS`,
so a range cannot differ between the two.  The validator stays the single
source of truth: a body that passes the schema can still be refused with a 422
naming the field (``A`` not square, ``Q`` not semidefinite, ...).
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

from kfio._version import __version__
from kfio.model import DECIMAL_PATTERN, DEFAULT_LIMITS, MAX_NUMBER_TEXT, MAX_SENSOR_NAME, OptionField, option_fields

#: The grammar of :func:`kfio.model.parse_number`, from its own pieces: ASCII digits, no whitespace.
NUMBER_PATTERN = rf"^{DECIMAL_PATTERN}(?:/{DECIMAL_PATTERN})?$"

#: An exact number written as text (its range is the validator's to check).
NUMBER_TEXT: dict[str, Any] = {"type": "string", "pattern": NUMBER_PATTERN, "maxLength": MAX_NUMBER_TEXT}


_KFIO_VERSION = {"type": "string", "description": "The version of kfio that made the report", "examples": [__version__]}


def schema_ref(name: str) -> dict[str, str]:
    return {"$ref": f"#/components/schemas/{name}"}


def json_bound(x: int | Fraction) -> int | float:
    """A bound of the table as a JSON number: an integer stays one, a fraction becomes its nearest float."""
    return int(x) if isinstance(x, int) or x.denominator == 1 else float(x)


def number_bounds(field: OptionField) -> dict[str, int | float]:
    """The JSON Schema keywords of ``field``'s range (``minimum``, ``exclusiveMaximum``, ...)."""
    out: dict[str, int | float] = {}
    if field.minimum is not None:
        out["exclusiveMinimum" if field.exclusive_minimum else "minimum"] = json_bound(field.minimum)
    if field.maximum is not None:
        out["exclusiveMaximum" if field.exclusive_maximum else "maximum"] = json_bound(field.maximum)
    return out


def exact_number(description: str, **bounds: Any) -> dict[str, Any]:
    """An exact number (a JSON number or its text) with numeric ``bounds`` on the JSON-number form."""
    return {"description": description, "anyOf": [{"type": "number", **bounds}, NUMBER_TEXT]}


def option_schema(field: OptionField) -> dict[str, Any]:
    """The JSON Schema of one option of :data:`kfio.model.OPTION_FIELDS`."""
    out: dict[str, Any]
    if field.kind == "integer":
        out = {"type": "integer", **number_bounds(field), "description": field.description}
    elif field.kind == "number":
        out = exact_number(field.description, **number_bounds(field))
        if field.max_text is not None:
            out["anyOf"][1] = {**NUMBER_TEXT, "maxLength": field.max_text}
    elif field.kind == "enum":
        out = {"enum": list(field.enum), "description": field.description}
    elif field.kind == "pointer":
        out = {"type": "string", "description": field.description}
    elif field.kind == "matrix":
        out = {**schema_ref("Matrix"), "description": field.description}
    elif field.kind == "probability_or_map":
        out = {
            "description": field.description,
            "anyOf": [
                schema_ref("Probability"),
                {
                    "type": "object",
                    "propertyNames": {"minLength": 1, "maxLength": MAX_SENSOR_NAME},
                    "minProperties": 1,
                    "maxProperties": DEFAULT_LIMITS.max_sensors,
                    "additionalProperties": schema_ref("Probability"),
                },
            ],
        }
    elif field.kind == "number_list":
        out = {
            "type": "array",
            "minItems": 1,
            "maxItems": field.max_items,
            "items": exact_number("one value", **number_bounds(field)),
            "description": field.description,
        }
    elif field.kind == "object":
        out = {
            "type": "object",
            "description": field.description,
            "properties": {p.name: option_schema(p) for p in field.properties},
            "required": list(field.required),
            "additionalProperties": False,
        }
    else:  # "fixed": the one value accepted
        out = {"const": list(field.default), "description": field.description}
    if field.default is not None and field.kind != "fixed":
        out["default"] = json_bound(field.default) if isinstance(field.default, Fraction) else field.default
    return out


def options_group_schema(group: str, description: str) -> dict[str, Any]:
    """The JSON Schema of one option group (``options.<group>``), every key from the table."""
    return {
        "type": "object",
        "description": description,
        "properties": {f.name: option_schema(f) for f in option_fields(group)},
        "additionalProperties": False,
    }


def _matrix(description: str) -> dict[str, Any]:
    # the widest a request may be (kfio analyze); the other commands refuse more states with a 422
    n = max(DEFAULT_LIMITS.max_analyze_states, DEFAULT_LIMITS.max_states)
    return {
        "type": "array",
        "minItems": 1,
        "maxItems": n,
        "items": {"type": "array", "minItems": 1, "maxItems": n, "items": schema_ref("ExactNumber")},
        "description": description,
    }


def _channel(
    model: str, properties: dict[str, Any], required: list[str], description: str, example: dict[str, Any]
) -> dict[str, Any]:
    return {
        "type": "object",
        "description": description,
        "properties": {"model": {"const": model}, **properties},
        "required": ["model", *required],
        "additionalProperties": False,
        "examples": [example],
    }


#: ``system.sensors``: at most :attr:`kfio.model.Limits.max_sensors` packets.
SENSORS: dict[str, Any] = {
    "type": "array",
    "minItems": 1,
    "maxItems": DEFAULT_LIMITS.max_sensors,
    "items": schema_ref("Sensor"),
}


# -- examples: the reference cases of the papers (docs/theory.md) -----------

_SEED004_SCALAR: dict[str, Any] = {
    "system": {"A": [[-1.25]], "C": [[1]], "Q": [[1]], "R": [[2.5]]},
    "channel": {"model": "bernoulli", "arrival_probability": 0.5},
}
_SEED004_3X3: dict[str, Any] = {
    "system": {
        "A": [[1.25, 1, 0], [0, 0.9, 7], [0, 0, 0.6]],
        "C": [[1, 0, 2]],
        "Q": [[20, 0, 0], [0, 20, 0], [0, 0, 20]],
        "R": [[2.5]],
    },
    "channel": {"model": "bernoulli", "arrival_probability": 0.5},
}
_SEED002_2X2: dict[str, Any] = {
    "system": {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]], "Q": [[20, 0], [0, 20]], "R": [[2.5]]},
    "channel": {"model": "bernoulli", "arrival_probability": 0.5},
}
_SEED001_DEGENERATE_GE: dict[str, Any] = {
    "system": {"A": [[1.1, 0], [0, -1.1]], "C": [[1, 1]], "Q": [[1, 0], [0, 1]], "R": [[1]]},
    "channel": {"model": "gilbert_elliott", "failure_rate": "1/10", "recovery_rate": "3/5"},
}
_SEED001_MARKOV: dict[str, Any] = {
    "system": {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]], "Q": [[20, 0], [0, 20]], "R": [[2.5]]},
    "channel": {
        "model": "markov",
        "order": 2,
        "arrival_probability": {"00": 0.4, "01": 0.7, "10": 0.5, "11": 0.9},
    },
    "options": {"time_budget_s": 10},
}
_SEED000_TWO_SENSORS: dict[str, Any] = {
    "system": {
        "A": [[2.5, 0], [0, 1.5]],
        "C": [[1, 0], [0, 1]],
        "Q": [[1, 0], [0, 1]],
        "R": [[1, 0], [0, 1]],
        "sensors": [{"name": "s1", "rows": [0]}, {"name": "s2", "rows": [1]}],
    },
    "channel": {
        "model": "per_sensor",
        "channels": {
            "s1": {"model": "bernoulli", "arrival_probability": 0.9},
            "s2": {"model": "bernoulli", "arrival_probability": 0.6},
        },
    },
}

#: ``kfio analyze --json`` on ``_SEED004_SCALAR`` (lambda_c = 9/25, as Sinopoli et al. (2004) finds).
_SEED004_SCALAR_REPORT: dict[str, Any] = {
    "kfio_version": __version__,
    "verdict": "stable",
    "theorem": "Rohr, Marelli and Fu 2014, Theorem 1",
    "blocks": [
        {
            "eigenvalues": ["-5/4"],
            "eigenvalues_numeric": [[-1.25, 0.0]],
            "modulus": 1.25,
            "modulus_exact": "5/4",
            "jordan_sizes": [1],
            "period": 1,
            "degenerate": False,
            "sigma": 0.5,
            "sigma_exact": "1/2",
            "rate": 0.78125,
            "verdict": "stable",
            "certified": True,
            "blind_set": [],
            "basis": "theorem",
            "notes": ["non-degenerate block: only the empty set is blind (Rohr, Marelli and Fu 2014, Lemma 2)"],
        }
    ],
    "critical_arrival_probability": 0.36,
    "critical_arrival_probability_exact": "9/25",
    "channel": {"model": "bernoulli", "order": 0, "arrival_probability": "1/2"},
    "system": {"n": 1, "p": 1, "controllable_A_Q": True},
    "assumptions": [],
    "warnings": [],
}

#: ``kfio bounds --json`` on ``_SEED004_SCALAR`` (abbreviated: P_hat_N for N = 1 and 8 only).
_SEED004_SCALAR_BOUNDS: dict[str, Any] = {
    "kfio_version": __version__,
    "command": "bounds",
    "packets": [{"name": None, "rows": [0], "arrival_probability": 0.5, "arrival_probability_exact": "1/2"}],
    "spectral_radius_A": 1.25,
    "hypotheses": {"A_unstable": True, "A_C_detectable": True, "A_Q_controllable": True},
    "operating_point": {
        "verdict_by_bounds": "stable",
        "reason": "the stability LMI is feasible here, certificate re-checked (Sinopoli et al. 2004, Theorems 3 and 5)",
        "certificate": {"method": "exact_rational", "at": ["1/2"], "margin": 0.21875},
    },
    "critical_probability": {
        "lower": {"value": 0.36, "formula": "max(0, 1 - 1/(rho(A)^2 prod_{other sensors r} (1 - lambda_r)))"},
        "upper": {"value": 0.360000152588, "exact": "90000038147/250000000000", "tolerance": 1e-06},
        "gap": 1.5258800001305417e-07,
    },
    "sensors": None,
    "variance_threshold": {"value": 0.5904, "formula": "max(0, 1 - 1/rho(A)^4)"},
    "covariance": {
        "S_bar": {"exists": True, "matrix": [[4.571428571428574]], "trace": 4.571428571428574},
        "V_bar": {"exists": True, "matrix": [[11.95589431671333]], "trace": 11.95589431671333},
        "ordering": {"S_bar_le_V_bar": True},
    },
    "p_hat": {
        "horizon": 8,
        "entries": [
            {"N": 1, "exists": True, "trace": 11.95589431671333, "improvement_over_P_hat_1_percent": 0.0},
            {
                "N": 8,
                "exists": True,
                "trace": 10.913904278352348,
                "improvement_over_P_hat_1_percent": 8.715283112735184,
            },
        ],
    },
    "region": None,
    "notes": [],
}

#: ``kfio simulate --json`` on ``_SEED004_SCALAR`` with steps 4, 1000 trajectories, seed 1 (rounded).
_SEED004_SCALAR_SIMULATION: dict[str, Any] = {
    "kfio_version": __version__,
    "steps": 4,
    "trajectories": 1000,
    "seed": 1,
    "initial_channel": "stationary",
    "P0": "Q",
    "mean_trace": [1.0, 2.3415, 3.7183, 5.097, 6.2907],
    "ci95_low": [1.0, 2.3277, 3.6619, 4.9718, 6.0689],
    "ci95_high": [1.0, 2.3554, 3.7748, 5.2223, 6.5125],
    "percentiles": {
        "50": [1.0, 2.5625, 2.9772, 5.3604, 4.0435],
        "90": [1.0, 2.5625, 5.0039, 8.8186, 13.0761],
        "99": [1.0, 2.5625, 5.0039, 8.8186, 14.7791],
    },
    "diverged": False,
    "mean_diverged_at": None,
    "percentile_diverged_at": {"50": None, "90": None, "99": None},
    "diverged_trajectories": 0,
    "final_mean_covariance": [[6.2907]],
    "checks": {"arrival_rate": {"packet": {"observed": 0.5025, "stationary": 0.5}}, "exact_agreement": None},
    "exact": None,
}

REQUEST_EXAMPLES: dict[str, dict[str, Any]] = {
    "seed004-scalar": {
        "summary": "Sinopoli et al. 2004, scalar system: lambda_c = 0.36 (stable at 0.5)",
        "value": _SEED004_SCALAR,
    },
    "seed004-3x3": {
        "summary": "Sinopoli et al. 2004, 3x3 system with one unstable eigenvalue: lambda_c = 0.36",
        "value": _SEED004_3X3,
    },
    "seed002-2x2": {
        "summary": "Sinopoli et al. 2004; Rohr, Marelli and Fu 2010, 2x2 system whose bounds differ (0.36 and about 0.48)",
        "value": _SEED002_2X2,
    },
    "seed001-degenerate-gilbert-elliott": {
        "summary": "Rohr, Marelli and Fu 2014, degenerate pair alpha diag(1, -1) over a Gilbert-Elliott channel (exact fractions as strings)",
        "value": _SEED001_DEGENERATE_GE,
    },
    "seed001-markov-order-2": {
        "summary": "Rohr, Marelli and Fu 2014, Markov channel of order 2 with a 10 s budget",
        "value": _SEED001_MARKOV,
    },
    "seed000-two-sensors": {
        "summary": "Liu and Goldsmith 2004, two packets: exact region lambda_1 > 0.84, lambda_2 > 5/9",
        "value": _SEED000_TWO_SENSORS,
    },
}

#: Example bodies for the plot endpoints (a subset that suits each plot).
PHASE_TRANSITION_EXAMPLES = {k: REQUEST_EXAMPLES[k] for k in ("seed004-3x3", "seed002-2x2", "seed004-scalar")}
REGION_EXAMPLES = {k: REQUEST_EXAMPLES[k] for k in ("seed000-two-sensors",)}
GE_REGION_EXAMPLES = {k: REQUEST_EXAMPLES[k] for k in ("seed001-degenerate-gilbert-elliott",)}


# -- component schemas ------------------------------------------------------

COMPONENTS: dict[str, dict[str, Any]] = {
    "ExactNumber": {
        "description": (
            "An exact number: a JSON number (read as its decimal text, so 1.1 is 11/10, never a binary double), "
            "or a string holding an integer, a decimal such as '1.1e-3' or a fraction such as '11/10'. "
            f"At most {DEFAULT_LIMITS.max_digits} digits."
        ),
        "anyOf": [{"type": "number"}, NUMBER_TEXT],
        "examples": [1.25, "11/10", "2.5e-1"],
    },
    "Probability": {
        "description": "An exact number in [0, 1] (as text too: '9/25'; the validator checks the range of text "
        "forms). A command may need more (its 422 names the rule).",
        "anyOf": [
            {"type": "number", "minimum": 0, "maximum": 1},
            NUMBER_TEXT,
        ],
        "examples": [0.5, "9/25"],
    },
    "Matrix": {
        **_matrix(
            f"A non-empty rectangular matrix, as an array of rows. At most {DEFAULT_LIMITS.max_analyze_states} "
            f"states for analyze, {DEFAULT_LIMITS.max_states} for every other command (a deployment may change "
            "both: KFIO_MAX_ANALYZE_STATES, KFIO_MAX_STATES)."
        ),
        "examples": [_SEED002_2X2["system"]["A"], [["5/4", 0], [1, "11/10"]]],
    },
    "Sensor": {
        "type": "object",
        "description": "A packet: the rows of C (and the block of R) it carries. Sensors partition the rows of C.",
        "properties": {
            "name": {"type": "string", "minLength": 1, "maxLength": MAX_SENSOR_NAME},
            "rows": {"type": "array", "minItems": 1, "items": {"type": "integer", "minimum": 0}},
        },
        "required": ["name", "rows"],
        "additionalProperties": False,
        "examples": [{"name": "s1", "rows": [0]}],
    },
    "System": {
        "type": "object",
        "description": "x[t+1] = A x + w, w ~ N(0, Q); y = C x + v, v ~ N(0, R) (see docs/theory.md, The model).",
        "properties": {
            "A": {**schema_ref("Matrix"), "description": "n x n state matrix"},
            "C": {**schema_ref("Matrix"), "description": "p x n output matrix"},
            "Q": {
                **schema_ref("Matrix"),
                "description": "n x n process noise covariance, symmetric positive semidefinite (JSON Schema cannot "
                "say symmetric or semidefinite: the validator checks both, exactly, and answers 422)",
            },
            "R": {
                **schema_ref("Matrix"),
                "description": "p x p measurement noise covariance, symmetric positive definite (checked exactly by "
                "the validator, 422 otherwise)",
            },
            "sensors": SENSORS,
        },
        "required": ["A", "C"],
        "additionalProperties": False,
        "examples": [_SEED002_2X2["system"]],
    },
    "BernoulliChannel": _channel(
        "bernoulli",
        {"arrival_probability": schema_ref("Probability")},
        ["arrival_probability"],
        "i.i.d. arrivals with P(arrival) = arrival_probability (Sinopoli et al. 2004).",
        _SEED004_SCALAR["channel"],
    ),
    "GilbertElliottChannel": _channel(
        "gilbert_elliott",
        {"failure_rate": schema_ref("Probability"), "recovery_rate": schema_ref("Probability")},
        ["failure_rate", "recovery_rate"],
        "failure_rate = P(lost | previous arrived), recovery_rate = P(arrived | previous lost).",
        _SEED001_DEGENERATE_GE["channel"],
    ),
    "MarkovChannel": _channel(
        "markov",
        {
            "order": {"type": "integer", "minimum": 0, "maximum": DEFAULT_LIMITS.max_markov_order},
            "arrival_probability": {
                "type": "object",
                "description": "P(arrival | last `order` outcomes), keyed by the history as 0/1 text, oldest first. "
                "Every key has exactly `order` characters and all 2^order histories are required (the validator "
                "checks both).",
                "propertyNames": {"pattern": f"^[01]{{0,{DEFAULT_LIMITS.max_markov_order}}}$"},
                "minProperties": 1,
                "maxProperties": 1 << DEFAULT_LIMITS.max_markov_order,
                "additionalProperties": schema_ref("Probability"),
            },
        },
        ["order", "arrival_probability"],
        "Finite-state Markov channel of order nu (Rohr, Marelli and Fu 2014, Definition 2); all 2^order histories are required.",
        _SEED001_MARKOV["channel"],
    ),
    "PerSensorChannel": _channel(
        "per_sensor",
        {
            "channels": {
                "type": "object",
                "description": "One independent channel per sensor name (requires system.sensors). The keys must "
                "be exactly the names in system.sensors, each once (the validator checks it: an unknown or "
                "missing name is 422).",
                "propertyNames": {"minLength": 1, "maxLength": MAX_SENSOR_NAME},
                "minProperties": 1,
                "maxProperties": DEFAULT_LIMITS.max_sensors,
                "additionalProperties": schema_ref("PacketChannel"),
            }
        },
        ["channels"],
        "Independent packet channels, one per sensor (Liu and Goldsmith 2004).",
        _SEED000_TWO_SENSORS["channel"],
    ),
    "PacketChannel": {
        "description": "The channel of one packet.",
        "oneOf": [schema_ref("BernoulliChannel"), schema_ref("GilbertElliottChannel"), schema_ref("MarkovChannel")],
        "examples": [_SEED001_DEGENERATE_GE["channel"]],
    },
    "Channel": {
        "oneOf": [
            schema_ref("BernoulliChannel"),
            schema_ref("GilbertElliottChannel"),
            schema_ref("MarkovChannel"),
            schema_ref("PerSensorChannel"),
        ],
        "examples": [{"model": "bernoulli", "arrival_probability": 0.5}],
    },
    "Options": {
        "type": "object",
        "description": "Per-command options (each command validates its own group) and the time budget.",
        "properties": {
            **{f.name: option_schema(f) for f in option_fields("")},
            "analyze": options_group_schema("analyze", "Options of the analyze command."),
            "bounds": options_group_schema("bounds", "Options of the bounds command."),
            "simulate": options_group_schema("simulate", "Options of the simulate command."),
        },
        "additionalProperties": False,
        "examples": [{"time_budget_s": 10}],
    },
    "AnalysisRequest": {
        "type": "object",
        "description": "The same JSON the kfio CLI reads from a file.",
        "properties": {
            "system": schema_ref("System"),
            "channel": {
                "anyOf": [schema_ref("Channel"), schema_ref("TraceChannel")],
                "description": "the packet channel; a measured trace (model trace) is read by kfio analyze only",
            },
            "options": schema_ref("Options"),
        },
        "required": ["system", "channel"],
        "additionalProperties": False,
        "examples": [_SEED002_2X2],
    },
    "StabilityReport": {
        "type": "object",
        "description": (
            "The report of `kfio analyze --json`: the verdict of Rohr, Marelli and Fu 2014, Theorem 1, with its evidence per "
            "finite multiplicative order (FMO) block: eigenvalues whose ratios are roots of unity.  "
            'Exact values are strings ("9/25"), their float approximations numbers.'
        ),
        "properties": {
            "kfio_version": _KFIO_VERSION,
            "verdict": {"type": "string", "enum": ["stable", "unstable", "boundary"]},
            "theorem": {"type": "string"},
            "blocks": {"type": "array", "items": {"type": "object"}},
            "critical_arrival_probability": {"type": ["number", "null"]},
            "critical_arrival_probability_exact": {"type": ["string", "null"]},
            "channel": {"type": "object"},
            "system": {"type": "object"},
            "assumptions": {"type": "array", "items": {"type": "string"}},
            "warnings": {"type": "array", "items": {"type": "string"}},
            "tail": {
                "type": ["object", "null"],
                "description": (
                    "Tail exponent kappa of the stationary error: P(trace P > M) ~ M^(-kappa), the moment of "
                    "order r finite iff kappa > r; per block kappa_k = log(1/sigma_k) / (2 log|alpha_k|), exact "
                    "text where sigma is.  basis 'theorem' (Mo and Sinopoli, 2012) for non-degenerate blocks, "
                    "'extension' otherwise."
                ),
            },
            "critical_parameter": {
                "type": ["object", "null"],
                "description": (
                    "With options.analyze.critical_parameter: the exact verdict on every interval of that one "
                    "parameter in (0, 1) and the critical values between them, with the deciding block and blind set."
                ),
            },
            "gilbert_elliott_region": {
                "type": ["object", "null"],
                "description": (
                    "Gilbert-Elliott channel only: the critical recovery rate q*(p) at the request's p and the "
                    "critical failure rate p*(q) at its q, exact and as floats, with the deciding block and blind "
                    "pattern; every boundary equation; and, with options.analyze.ge_grid, the exactly labelled "
                    "(p, q) map and its boundary curve (Theorem 1 of Rohr, Marelli and Fu, 2014, on the family)."
                ),
            },
        },
        "required": ["kfio_version", "verdict", "blocks"],
        "examples": [_SEED004_SCALAR_REPORT],
    },
    "BoundsReport": {
        "type": "object",
        "description": (
            "The report of `kfio bounds --json`: bounds on the critical arrival probability (closed-form lower, "
            "certified LMI upper), S_bar <= lim E[P_t] <= V_bar at the operating point, the P_hat_N of Rohr, Marelli and Fu 2010 for "
            "one packet, and the region map for two packets when options.bounds.grid is set."
        ),
        "properties": {
            "kfio_version": _KFIO_VERSION,
            "command": {"const": "bounds"},
            "packets": {"type": "array", "items": {"type": "object"}},
            "spectral_radius_A": {"type": ["number", "null"]},
            "hypotheses": {"type": "object"},
            "operating_point": {
                "type": "object",
                "properties": {"verdict_by_bounds": {"type": "string", "enum": ["stable", "unstable", "undecided"]}},
                "required": ["verdict_by_bounds"],
            },
            "critical_probability": {"type": ["object", "null"]},
            "sensors": {"type": ["array", "null"]},
            "variance_threshold": {"type": ["object", "null"]},
            "covariance": {
                "type": "object",
                "description": (
                    "S_bar and V_bar bound lim E[P(t|t-1)], the one-step predictor (Sinopoli et al. 2004, "
                    "Theorems 3-4).  covariance.filtered gives the filtered P(t|t) counterparts: lower "
                    "pi(nothing arrives) S_bar, upper sum_S pi(S) (V_bar - V_bar C_S'(C_S V_bar C_S' + R_SS)^-1 "
                    "C_S V_bar), valid because the measurement update is monotone and concave in P and the "
                    "arrivals at t are independent of P(t|t-1)."
                ),
            },
            "p_hat": {
                "type": ["object", "null"],
                "description": "P_hat_N bounds the predictor (Rohr, Marelli and Fu 2010); each entry's "
                "filtered_trace bounds the filtered P(t|t) the same way as covariance.filtered.upper.",
            },
            "region": {"type": ["object", "null"]},
            "notes": {"type": "array", "items": {"type": "string"}},
        },
        "required": ["kfio_version", "command", "packets", "operating_point", "covariance"],
        "examples": [_SEED004_SCALAR_BOUNDS],
    },
    "SimulationReport": {
        "type": "object",
        "description": (
            "The report of `kfio simulate --json`: statistics of trace(P_t) over Monte Carlo trajectories, "
            "t = 0..steps (null where a trajectory diverged)."
        ),
        "properties": {
            "kfio_version": _KFIO_VERSION,
            "steps": {"type": "integer"},
            "trajectories": {"type": "integer"},
            "seed": {"type": "integer"},
            "mean_trace": {"type": "array", "items": {"type": ["number", "null"]}},
            "ci95_low": {"type": "array", "items": {"type": ["number", "null"]}},
            "ci95_high": {"type": "array", "items": {"type": ["number", "null"]}},
            "percentiles": {
                "type": "object",
                "additionalProperties": {"type": "array", "items": {"type": ["number", "null"]}},
            },
            "diverged": {"type": "boolean"},
            "checks": {"type": "object"},
            "exact": {
                "type": ["object", "null"],
                "description": "Exact E[P(t|t-1)] (mean_trace) and E[P(t|t)] (filtered_mean_trace) by "
                "enumeration of the arrival sequences.",
            },
            "covariance": {
                "type": "string",
                "description": "mean_trace, ci95_*, percentiles and final_mean_covariance describe the "
                "one-step predictor P(t|t-1).",
            },
            "filtered": {
                "type": ["object", "null"],
                "description": "The same statistics for the filtered P(t|t) = P - P C_S'(C_S P C_S' + R_SS)^-1 "
                "C_S P, computed per trajectory from the predictor and the same arrivals.",
            },
            "outage_target": {
                "type": ["object", "null"],
                "description": "With options.simulate.outage_target: the smallest arrival probability at "
                "which the estimated stationary outage P(trace P > M) is at most epsilon, and the bracket "
                "[confidently_insufficient, confidently_sufficient] where its Wilson 95% interval straddles "
                "epsilon; label 'estimated'.",
            },
            "stationary": {
                "type": ["object", "null"],
                "description": (
                    "trace(P_T) over the trajectories at the last step (P_t converges in distribution: Kar, "
                    "Sinopoli and Moura, 2012): quantiles with 95% intervals, outage P(trace P > M) for "
                    "options.simulate.outage_thresholds with Wilson intervals, Hill's tail exponent beside the "
                    "exact kappa (Mo and Sinopoli, 2012), the exact per-step growth of E[P_t], and a warning "
                    "when kappa <= 2 (the sample mean is then unreliable)."
                ),
            },
        },
        "required": ["kfio_version", "steps", "trajectories", "seed", "mean_trace", "percentiles", "diverged"],
        "examples": [_SEED004_SCALAR_SIMULATION],
    },
    "Problem": {
        "type": "object",
        "description": "RFC 9457 problem details.",
        "properties": {
            "type": {"type": "string", "description": "urn:kfio:problem:<kind>"},
            "title": {"type": "string"},
            "status": {"type": "integer"},
            "detail": {"type": "string"},
            "field": {"type": "string", "description": "JSON pointer (RFC 6901) to the offending value"},
            "rule": {"type": "string", "description": "The rule that was broken"},
            "in": {
                "type": "string",
                "enum": ["body", "query", "path", "header"],
                "description": "Where `field` points: a JSON pointer into the body, or the name of a query "
                "parameter, path parameter or header",
            },
            "sigma_bracket": {
                "type": "object",
                "description": "budget-exceeded only, when the search for sigma_k over several Bernoulli sensors "
                "was cut short: the bracket on sigma_k it had proved (sigma_lower, sigma_upper, each with what "
                "proves it) and what the bracket already decides (docs/sigma.md)",
            },
        },
        "required": ["type", "title", "status", "detail"],
        "examples": [
            {
                "type": "urn:kfio:problem:invalid-input",
                "title": "Invalid request",
                "status": 422,
                "detail": "/system/C: C must have 2 columns (A is 2x2); got 1",
                "field": "/system/C",
                "rule": "C must have 2 columns (A is 2x2); got 1",
                "in": "body",
            }
        ],
    },
    "Health": {
        "type": "object",
        "properties": {"status": {"type": "string", "enum": ["ok"]}},
        "required": ["status"],
        "examples": [{"status": "ok"}],
    },
    "Readiness": {
        "type": "object",
        "properties": {
            "status": {"type": "string", "enum": ["ready"]},
            "pool": {"type": "object", "additionalProperties": {"type": "integer"}},
            "cache": {"type": "object", "additionalProperties": {"type": "integer"}},
            "jobs": {
                "type": "object",
                "description": "the job lane: its workers, the queue bound, and jobs held by status",
                "additionalProperties": {"type": "integer"},
            },
        },
        "required": ["status", "pool", "cache"],
        "examples": [
            {
                "status": "ready",
                "pool": {"size": 2, "alive": 2, "busy": 0, "waiting": 0, "completed": 17, "replaced": 0},
                "cache": {"entries": 12, "bytes": 40960, "hits": 5, "misses": 12},
            }
        ],
    },
}


def problem_responses(*statuses: int) -> dict[int | str, dict[str, Any]]:
    """OpenAPI ``responses`` entries for problem documents."""
    texts = {
        404: "No such job (unknown, forgotten after the retention limit, or the server restarted)",
        409: "The job is not in a state that allows this (already finished, or no result yet)",
        413: "Request body larger than the deployment's limit (1 MiB by default)",
        415: "The body was not sent as Content-Type: application/json",
        422: "Invalid request: the problem names the field (JSON pointer) and the rule; or the "
        "computation needs more memory than one analysis process may use (memory-exceeded)",
        429: "Too many jobs are queued (the deployment's `KFIO_MAX_JOBS`); retry later",
        503: "No worker became free in time, a worker died, or the server is shutting down; retry later",
        504: "The computation did not finish within its time budget",
    }
    if 413 in statuses and 415 not in statuses:  # a route that reads a body refuses other media types too
        statuses = (*statuses, 415)
    return {
        s: {"description": texts[s], "content": {"application/problem+json": {"schema": schema_ref("Problem")}}}
        for s in sorted(statuses)
    }


def json_body(examples: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """``openapi_extra`` for a route that reads an :ref:`AnalysisRequest` itself."""
    return {
        "requestBody": {
            "required": True,
            "content": {"application/json": {"schema": schema_ref("AnalysisRequest"), "examples": examples}},
        }
    }


def json_response(schema_name: str, description: str) -> dict[int | str, dict[str, Any]]:
    """A 200 JSON response with a component schema."""
    return {200: {"description": description, "content": {"application/json": {"schema": schema_ref(schema_name)}}}}
