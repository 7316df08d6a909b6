"""OpenAPI component schemas of ``kfio loop`` (merged into the service's components on import)."""

from __future__ import annotations

from typing import Any

from kfio.model import option_fields

from ..._version import __version__
from .schemas import COMPONENTS, SENSORS, option_schema, options_group_schema, schema_ref

LOOP_EXAMPLE: dict[str, Any] = {
    "system": {"A": [[1.25]], "B": [[1]], "C": [[1]], "Q": [[1]], "R": [[0.5]]},
    "channel": {"model": "bernoulli", "arrival_probability": 0.8},
    "actuator_channel": {"model": "bernoulli", "arrival_probability": 0.9},
    "controller": {"gains": {"feedback": [[0.6]], "estimator": [[0.5]]}, "form": "predictor"},
    "cost": {"W": [[1]], "U": [[0.5]]},
    "options": {"loop": {"protocol": "tcp", "on_loss": "zero"}},
}

LOOP_EXAMPLES = {"scalar-loop": {"summary": "A scalar loop, Bernoulli links on both sides", "value": LOOP_EXAMPLE}}

_WEIGHTS = {
    "type": "object",
    "properties": {
        "W": {**schema_ref("Matrix"), "description": "n x n state weight, symmetric positive semidefinite (default I)"},
        "U": {**schema_ref("Matrix"), "description": "m x m input weight, symmetric positive semidefinite (default 0)"},
    },
    "additionalProperties": False,
}

#: A proved enclosure ``[lo, hi]`` as two decimal texts.
_ENCLOSURE: dict[str, Any] = {"type": ["array", "null"], "items": {"type": "string"}, "minItems": 2, "maxItems": 2}

LOOP_COMPONENTS: dict[str, dict[str, Any]] = {
    "LoopRequest": {
        "type": "object",
        "description": (
            "A closed loop over lossy links (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007): "
            "x[t+1] = A x + B a + w, y = C x + v; the sensor packets travel over `channel`, the actuator packets "
            "over `actuator_channel`; u = -F x_hat with F = gains.feedback (python-control's dlqr K) and the "
            "estimator gain gains.estimator in predictor form (python-control's dlqe L) or filter form.  See docs/loop.md."
        ),
        "properties": {
            "system": {
                "type": "object",
                "description": "The System fields (A, C, Q, R and sensors; Q and R required) plus B (n x m).",
                "properties": {
                    "A": schema_ref("Matrix"),
                    "B": schema_ref("Matrix"),
                    "C": schema_ref("Matrix"),
                    "Q": schema_ref("Matrix"),
                    "R": schema_ref("Matrix"),
                    "sensors": SENSORS,
                },
                "required": ["A", "B", "C", "Q", "R"],
                "additionalProperties": False,
            },
            "channel": {"anyOf": [schema_ref("Channel"), schema_ref("TraceChannel")]},
            "actuator_channel": {
                "anyOf": [
                    schema_ref("BernoulliChannel"),
                    schema_ref("GilbertElliottChannel"),
                    schema_ref("MarkovChannel"),
                    schema_ref("TraceChannel"),
                ]
            },
            "controller": {
                "anyOf": [
                    {
                        "type": "object",
                        "properties": {
                            "gains": {
                                "type": "object",
                                "properties": {
                                    "feedback": {
                                        **schema_ref("Matrix"),
                                        "description": "m x n feedback gain F, u = -F x_hat (python-control's dlqr K)",
                                    },
                                    "estimator": {
                                        **schema_ref("Matrix"),
                                        "description": "n x p estimator gain (python-control's dlqe L in "
                                        "predictor form)",
                                    },
                                },
                                "required": ["feedback", "estimator"],
                                "description": "gains named by role; the letters K and L are refused (the paper "
                                "and python-control use them the other way round)",
                                "additionalProperties": False,
                            },
                            "form": {"enum": ["predictor", "filter"]},
                        },
                        "required": ["gains"],
                        "additionalProperties": False,
                    },
                    {
                        "type": "object",
                        "properties": {
                            "lqg": _WEIGHTS,
                            "form": {
                                "enum": ["filter", "predictor"],
                                "description": "estimator form of the stationary LQG gains; filter (default) is the "
                                "optimal TCP-like controller's structure, u = -L x_hat[t|t]",
                            },
                        },
                        "required": ["lqg"],
                        "additionalProperties": False,
                    },
                ]
            },
            "cost": _WEIGHTS,
            "options": {
                "type": "object",
                "properties": {
                    "loop": options_group_schema("loop", "Options of the loop command."),
                    **{f.name: option_schema(f) for f in option_fields("")},
                },
                "additionalProperties": False,
            },
        },
        "required": ["system", "channel", "actuator_channel", "controller"],
        "additionalProperties": False,
        "examples": [LOOP_EXAMPLE],
    },
    "LoopReport": {
        "type": "object",
        "description": (
            "The report of `kfio loop --json`: the exact mean-square verdict (Costa, Fragoso and Marques 2005, "
            "Thm 3.9), the stationary cost (null when unbounded) and the critical arrival probability of each "
            'link alone.  Exact values are strings ("9/16"), their float approximations numbers.'
        ),
        "properties": {
            "kfio_version": {"type": "string"},
            "verdict": {"type": "string", "enum": ["stable", "unstable", "boundary"]},
            "exact": {"type": "boolean"},
            "certified": {"type": "boolean"},
            "partial": {
                "type": "boolean",
                "description": "true when options.time_budget_s ran out after the verdict and cost: the notes "
                "name what was not computed (critical values, region, LQG cost bounds)",
            },
            "spectral_radius": {"type": ["number", "null"]},
            "spectral_radius_exact": {"type": ["string", "null"]},
            "spectral_radius_enclosure": {
                **_ENCLOSURE,
                "description": "decimal texts [lo, hi] proved to enclose rho(T) on the certified route "
                "(verified Collatz-Wielandt bounds); null on the exact route",
            },
            "cost": {"type": ["number", "null"]},
            "cost_exact": {"type": ["string", "null"]},
            "cost_exact_digits": {
                "type": ["integer", "null"],
                "description": "digits of the exact cost's fraction text; null when the exact cost was not "
                "computed (certified route) or the cost is unbounded",
            },
            "cost_enclosure": {
                **_ENCLOSURE,
                "description": "decimal texts [lo, hi] proved to enclose the stationary cost: when its exact text "
                "would pass 200 digits (cost_exact is then null), or on the certified route (verified residual of "
                "the float moments measured by the Lyapunov certificate's margin)",
            },
            "critical_sensor_arrival_probability": {"type": ["number", "null"]},
            "critical_sensor_arrival_probability_exact": {"type": ["string", "null"]},
            "critical_actuator_arrival_probability": {"type": ["number", "null"]},
            "critical_actuator_arrival_probability_exact": {"type": ["string", "null"]},
            "critical_values": {
                "type": "array",
                "items": {
                    "type": "object",
                    "description": "per link: value, value_exact (null past 200 digits), value_minimal_polynomial "
                    "(null when a coefficient passes 200 digits; value_minimal_polynomial_degree and _digits then say "
                    "how big), value_enclosure, value_bracket and value_bracket_exact (a certified bracket by "
                    "bisection on proved verdicts, for operators too large for the exact value), intervals, note",
                },
            },
            "estimator_alone": {
                "type": ["object", "null"],
                "description": "null when there are no gains (LQG below the optimal critical values)",
            },
            "region": {"type": ["object", "null"]},
            "lqg": {
                "type": ["object", "null"],
                "description": "with controller.lqg: optimal, the optimal TCP-like controller (Schenato, Sinopoli, "
                "Franceschetti, Poolla and Sastry 2007, Sec. V): its verdict and reasons, the critical sensor "
                "arrival probability of the optimal filter (Rohr, Marelli and Fu 2014, Theorem 1), the control "
                "MARE's critical actuator arrival probability (exact for one input, Elia 2005, and square "
                "invertible B; else a certified bracket), cost_bounds (lower <= J_inf <= upper) and a statement "
                "beside the stationary gains' critical values; and stationary_gains, how the gains the top level "
                "analyzes were derived (exist: false below the optimal critical values, where the top level is "
                "unstable without gains or cost)",
                "properties": {
                    "optimal": {
                        "type": "object",
                        "properties": {
                            "verdict": {"enum": ["stable", "unstable"]},
                            "reasons": {"type": "array", "items": {"type": "string"}},
                            "critical_sensor_arrival_probability": {"type": ["number", "null"]},
                            "critical_sensor_arrival_probability_exact": {"type": ["string", "null"]},
                            "critical_actuator_arrival_probability": {"type": ["number", "null"]},
                            "critical_actuator_arrival_probability_exact": {"type": ["string", "null"]},
                            "critical_actuator": {
                                "type": "object",
                                "properties": {
                                    "lower": {"type": ["number", "null"]},
                                    "upper": {"type": ["number", "null"]},
                                    "is_exact": {"type": "boolean"},
                                    "from": {"type": "string"},
                                    "stabilizable": {"type": "boolean"},
                                },
                            },
                            "cost_bounds": {"type": "object"},
                            "statement": {"type": ["string", "null"]},
                        },
                        "required": ["verdict", "reasons", "critical_actuator", "cost_bounds"],
                    },
                    "stationary_gains": {
                        "type": "object",
                        "properties": {
                            "exist": {"type": "boolean"},
                            "form": {"enum": ["filter", "predictor"]},
                            "control_riccati": {"type": ["object", "null"]},
                            "estimation_riccati": {"type": ["object", "null"]},
                        },
                        "required": ["exist", "form"],
                    },
                },
                "required": ["optimal", "stationary_gains"],
            },
            "udp_region_bounds": {
                "type": ["object", "null"],
                "description": "with protocol udp: outer bounds (necessary sensor and actuator arrival "
                "probabilities for any design) and the inner bound (the given gains' exact stable region) on the "
                "optimal UDP-like controller's critical region, labelled as bounds",
            },
            "loop": {"type": "object"},
        },
        "required": ["kfio_version", "verdict", "spectral_radius", "cost", "certified"],
        "examples": [
            {  # kfio loop --json examples/loop_scalar.json (abridged)
                "kfio_version": __version__,
                "verdict": "stable",
                "exact": True,
                "certified": True,
                "spectral_radius": 0.7625,
                "spectral_radius_exact": "61/80",
                "cost": 18.339837542615296,
                "cost_exact": "256154510/13967109",
                "critical_sensor_arrival_probability": 0.5625,
                "critical_sensor_arrival_probability_exact": "9/16",
                "critical_actuator_arrival_probability": 0.4934210526315789,
                "critical_actuator_arrival_probability_exact": "75/152",
            }
        ],
    },
}

COMPONENTS.update(LOOP_COMPONENTS)

__all__ = ["LOOP_COMPONENTS", "LOOP_EXAMPLE", "LOOP_EXAMPLES"]
