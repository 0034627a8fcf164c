"""JSON schemas of the fit and profile results, written from CONTRACT.md (not from the code)."""

from __future__ import annotations

from typing import Any

NUMBER = {"type": "number"}
NULLABLE_NUMBER = {"type": ["number", "null"]}
FMU = {
    "type": "object",
    "required": ["sha256", "model_name"],
    "properties": {"sha256": {"type": "string", "pattern": "^[0-9a-f]{64}$"}},
}
COST = {"type": "object", "required": ["simulations", "seconds"]}

FIT: dict[str, Any] = {
    "type": "object",
    "required": ["fmu", "n_data", "chi2", "sigma", "parameters", "cost"],
    "properties": {
        "fmu": FMU,
        "n_data": {"type": "integer", "minimum": 1},
        "chi2": NUMBER,
        "sigma": {"type": "object", "additionalProperties": NUMBER},
        "parameters": {
            "type": "object",
            "minProperties": 1,
            "additionalProperties": {
                "type": "object",
                "required": ["estimate", "lower", "upper"],
                "properties": {"estimate": NUMBER, "lower": NUMBER, "upper": NUMBER},
            },
        },
        "cost": COST,
    },
}

PROFILE_POINT = {
    "type": "object",
    "required": ["value", "chi2", "params", "at_bound"],
    "properties": {
        "value": NUMBER,
        "chi2": NULLABLE_NUMBER,
        "params": {"type": "object", "additionalProperties": NUMBER},
        "at_bound": {"type": "array", "items": {"type": "string"}},
        "error": {"type": "string"},
    },
}
INTERVAL = {"type": "array", "items": NULLABLE_NUMBER, "minItems": 2, "maxItems": 2}

PROFILE: dict[str, Any] = {
    "type": "object",
    "required": [
        "fmu",
        "n_data",
        "chi2",
        "confidence",
        "thresholds",
        "sigma",
        "parameters",
        "better_optimum_found",
        "structural_check",
        "cost",
    ],  # fmt: skip
    "properties": {
        "fmu": FMU,
        "n_data": {"type": "integer", "minimum": 1},
        "chi2": NUMBER,
        "confidence": {"type": "number", "exclusiveMinimum": 0, "exclusiveMaximum": 1},
        "thresholds": {
            "type": "object",
            "required": ["pointwise", "simultaneous"],
            "properties": {"pointwise": NUMBER, "simultaneous": NUMBER},
        },
        "sigma": {"type": "object", "additionalProperties": NUMBER},
        "parameters": {
            "type": "object",
            "minProperties": 1,
            "additionalProperties": {
                "type": "object",
                "required": ["estimate", "lower", "upper", "ci", "status", "profile"],
                "properties": {
                    "estimate": NUMBER,
                    "ci": {
                        "type": "object",
                        "required": ["simultaneous", "pointwise"],
                        "properties": {"simultaneous": INTERVAL, "pointwise": INTERVAL},
                    },
                    "status": {
                        "enum": [
                            "identifiable",
                            "practically_non_identifiable",
                            "structurally_non_identifiable",
                        ]
                    },
                    "profile": {"type": "array", "items": PROFILE_POINT},
                },
            },
        },
        "better_optimum_found": {"type": "boolean"},
        "structural_check": {
            "type": "object",
            "required": ["singular_values", "non_identifiable_combinations"],
        },
        "cost": COST,
    },
}

SCHEMAS = {"fit": FIT, "profile": PROFILE}
