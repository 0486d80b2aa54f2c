"""JSON Schema (draft-07) of the mission format, generated from
:mod:`mission.format`, the table the loader reads every field through.

For editors: with the YAML language server (VS Code, Neovim, ...), a first
line ``# yaml-language-server: $schema=../docs/mission.schema.json`` gives
completion, hover help and shape checks while typing. The schema checks the
shape only (keys, types, ranges, required fields); ``maris validate`` also
checks references (actions, subtrees, blackboard keys, devices) and the
safety lint. ``maris schema`` prints it; ``docs/mission.schema.json`` is the
shipped copy (a test keeps it equal to this output).
"""

from __future__ import annotations

import json
from typing import Any

from . import format as fmt
from .spec import NODE_ALIASES

SCHEMA_ID = "https://maris-uvms.invalid/mission.schema.json"


def _ref(name: str) -> dict:
    return {"$ref": f"#/definitions/{name}"}


_STRUCTURED = {
    "node": _ref("node"),
    "nodes": {"type": "array", "minItems": 1, "items": _ref("node")},
    "condition": _ref("condition"),
    "targets": _ref("targets"),
    "goal": _ref("goal"),
    "goals": {"type": "array", "minItems": 1, "items": _ref("goal")},
    "track": _ref("track_detection"),
    "safety": _ref("safety"),
    "rates": _ref("rates"),
    "geofence": _ref("geofence"),
    "watchdog": _ref("watchdog"),
    "blackboard": _ref("blackboard"),
    "subtrees": _ref("subtrees"),
    "handback": _ref("handback"),
    "interval": {"type": "array", "minItems": 2, "maxItems": 2, "items": {"type": "number"}},
    "scalar": {"type": ["number", "string", "boolean"]},
    "any": {},
}


def field_schema(f: fmt.Field) -> dict:
    """The schema of one field's value."""
    if f.type in ("number", "integer"):
        out: dict[str, Any] = {"type": f.type}
        if f.lo is not None:
            out["exclusiveMinimum" if f.lo_open else "minimum"] = f.lo
        if f.hi is not None:
            out["maximum"] = f.hi
    elif f.type == "bool":
        out = {"type": "boolean"}
    elif f.type == "string":
        out = {"type": "string", "minLength": 1}
    elif f.type == "choice":
        out = {"type": "string", "enum": list(f.choices)}
    elif f.type == "choices":
        out = {
            "type": "array",
            "minItems": 1,
            "uniqueItems": True,
            "items": {"type": "string", "enum": list(f.choices)},
        }
    else:
        out = dict(_STRUCTURED[f.type])
    if f.nullable:
        out = {"anyOf": [out, {"type": "null"}]}
    if f.doc:
        out["description"] = f.doc
    if f.default is not None and f.default is not fmt.REQUIRED and f.type not in _STRUCTURED:
        out["default"] = list(f.default) if isinstance(f.default, tuple) else f.default
    return out


def object_schema(spec: dict[str, fmt.Field], doc: str = "", **extra: Any) -> dict:
    """A mapping with exactly the fields of ``spec``."""
    out: dict[str, Any] = {
        "type": "object",
        "properties": {name: field_schema(f) for name, f in spec.items()},
        "additionalProperties": False,
    }
    required = [name for name, f in spec.items() if f.required]
    if required:
        out["required"] = required
    if doc:
        out["description"] = doc
    out.update(extra)
    return out


def _node_kind(kind: str, body: dict) -> dict:
    return {
        "type": "object",
        "properties": {kind: body},
        "required": [kind],
        "additionalProperties": False,
        "description": fmt.NODE_DOCS.get(kind, ""),
    }


def _condition_body(kind: str) -> dict:
    spec = fmt.CONDITION_FIELDS[kind]
    body = object_schema(spec, fmt.CONDITION_DOCS[kind])
    if kind in ("depth_m", "altitude_m", "force_n"):
        body["anyOf"] = [{"required": ["min"]}, {"required": ["max"]}]
    elif kind == "blackboard":
        body["oneOf"] = [{"required": [op]} for op in fmt.COMPARISONS]
    elif kind in fmt.BARE_CONDITIONS:
        return {"anyOf": [body, {"type": "null"}, {"const": True}], "description": fmt.CONDITION_DOCS[kind]}
    return body


def mission_schema() -> dict:
    """The whole schema (a JSON-able dict)."""
    defs: dict[str, Any] = {}
    conditions = [
        {"type": "object", "properties": {k: _condition_body(k)}, "required": [k], "additionalProperties": False}
        for k in fmt.CONDITION_FIELDS
    ]
    defs["condition"] = {
        "description": "a condition: {kind: {fields}}, or the bare word converged / detected",
        "oneOf": [{"type": "string", "enum": list(fmt.BARE_CONDITIONS)}, *conditions],
    }
    kinds = []
    for kind, spec in fmt.NODE_FIELDS.items():
        body = object_schema(spec)
        if kind == "condition":  # a name and exactly one condition kind, or a bare word
            props = {"name": field_schema(fmt.NAME)}
            props.update({k: _condition_body(k) for k in fmt.CONDITION_FIELDS})
            body = {
                "anyOf": [
                    {"type": "string", "enum": list(fmt.BARE_CONDITIONS)},
                    {
                        "type": "object",
                        "properties": props,
                        "additionalProperties": False,
                        "oneOf": [{"required": [k]} for k in fmt.CONDITION_FIELDS],
                    },
                ]
            }
        elif kind == "subtree":
            body = {"anyOf": [{"type": "string", "minLength": 1}, body]}
        elif kind == "gripper":
            body["allOf"] = [
                {
                    "if": {"properties": {"command": {"const": "close"}}},
                    "then": {"required": ["current_limit_a"]},
                    "else": {"not": {"required": ["current_limit_a"]}},
                },
                {
                    "if": {"properties": {"command": {"const": "preshape"}}},
                    "then": {"required": ["shape"]},
                    "else": {"not": {"required": ["shape"]}},
                },
            ]
        elif kind == "set":
            body["oneOf"] = [{"required": ["value"]}, {"required": ["add"]}]
        kinds.append(_node_kind(kind, body))
        for alias, target in NODE_ALIASES.items():
            if target == kind:
                kinds.append(_node_kind(alias, body))
    defs["node"] = {"description": "a tree node: a mapping with one key, its kind", "oneOf": kinds}
    defs["goal"] = object_schema(
        fmt.GOAL,
        "a vehicle goal; missing fields keep the previous goal's",
        **{"not": {"required": ["down_m", "altitude_m"]}},
    )
    defs["targets"] = object_schema(
        fmt.TARGETS, "what the action aims at", **{"not": {"required": ["vehicle_goal", "waypoints"]}}
    )
    defs["track_detection"] = object_schema(fmt.TRACK)
    defs["handback"] = object_schema(fmt.HANDBACK, "how the operator gives control back (at least one way)")
    defs["rates"] = object_schema(fmt.RATES, "loop rates (tree_hz <= vehicle_hz <= arm_hz)")
    defs["geofence"] = object_schema(fmt.GEOFENCE)
    defs["watchdog"] = object_schema(fmt.WATCHDOG)
    defs["safety"] = object_schema(fmt.SAFETY)
    entry = object_schema(fmt.BLACKBOARD_ENTRY)
    defs["blackboard"] = {
        "type": "object",
        "description": "key -> initial value, or {type, value}",
        "propertyNames": {"pattern": "^[A-Za-z_][A-Za-z0-9_]*$"},
        "additionalProperties": {"anyOf": [{"type": ["boolean", "number", "string"]}, entry]},
    }
    defs["subtrees"] = {
        "type": "object",
        "propertyNames": {"pattern": "^[A-Za-z_][A-Za-z0-9_]*$"},
        "additionalProperties": _ref("node"),
    }
    top = object_schema(fmt.TOP)
    return {
        "$schema": "http://json-schema.org/draft-07/schema#",
        "$id": SCHEMA_ID,
        "title": "maris mission",
        "description": "A maris-uvms mission file (docs/missions.md). Generated by `maris schema` from mission/format.py.",
        **{k: v for k, v in top.items() if k != "description"},
        "definitions": defs,
    }


def schema_text() -> str:
    """The schema as the text of ``docs/mission.schema.json``."""
    return json.dumps(mission_schema(), indent=2) + "\n"
