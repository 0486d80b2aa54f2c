"""Parsing of tree nodes and predicates (the ``tree:``, ``subtrees:`` and
``abort:`` sections of a mission file) into :class:`mission.spec.Node`.

A node is written as a one-key mapping ``{<kind>: <body>}``; the body is a
mapping of that kind's fields. ``docs/missions.md`` is the user reference for
every kind; this module is its executable form. Shape and range errors are
collected in the :class:`mission.schema.Reader`; cross references (actions,
subtrees, blackboard keys, devices) are checked later in :mod:`mission.checks`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from maris_common.yamlsrc import suggest

from . import format as fmt
from .schema import MISSING, Reader, is_number, type_name
from .spec import NODE_ALIASES, NODE_KINDS, PREDICATE_KINDS, Node, Predicate

GRIPPER_COMMANDS = fmt.NODE_FIELDS["gripper"]["command"].choices
PARALLEL_POLICIES = fmt.NODE_FIELDS["parallel"]["policy"].choices
ONE_SHOT_ON = fmt.NODE_FIELDS["one_shot"]["on"].choices
LOG_LEVELS = fmt.NODE_FIELDS["log"]["level"].choices  # the run log's event levels
COMPARISONS = fmt.COMPARISONS
GOAL_KEYS = tuple(fmt.GOAL)
TARGET_KEYS = tuple(fmt.TARGETS)


# --------------------------------------------------------------------------- predicates


def parse_predicate(r: Reader, value: Any, path: tuple) -> Predicate | None:
    """A predicate: ``{<kind>: <params>}``, or the bare word ``converged`` / ``detected``."""
    if isinstance(value, str):
        if value in fmt.BARE_CONDITIONS:
            return _PREDICATE_PARSERS[value](r, {}, path, value)
        if value in PREDICATE_KINDS:
            r.error(
                path,
                f"condition `{value}` needs its fields, e.g. {{{value}: {_example(value)}}}; "
                f"only {' and '.join(fmt.BARE_CONDITIONS)} may be written as a bare word",
            )
            return None
        r.error(
            path,
            f"unknown condition `{value}`{suggest(value, PREDICATE_KINDS)}; expected one of: {', '.join(PREDICATE_KINDS)}",
        )
        return None
    m = r.mapping(value, path, "a condition mapping such as {detected: {min_confidence: 0.6}}")
    if m is None:
        return None
    if len(m) != 1:
        r.error(path, f"a condition has exactly one kind (one of: {', '.join(PREDICATE_KINDS)}), got {len(m)} keys")
        return None
    ((kind, body),) = m.items()
    if kind not in PREDICATE_KINDS:
        r.key_error(
            path + (kind,),
            f"unknown condition `{kind}`{suggest(str(kind), PREDICATE_KINDS)}; expected one of: {', '.join(PREDICATE_KINDS)}",
        )
        return None
    return _PREDICATE_PARSERS[kind](r, body, path + (kind,), kind)


def _example(kind: str) -> str:
    return {"grasp_detected": "{current_a: 0.8}", "blackboard": "{key: attempts, below: 3}"}.get(kind, "{min: 1.0}")


def _body(r: Reader, body: Any, path: tuple, kind: str) -> dict | None:
    """Predicate body: a mapping (None and ``true`` count as empty)."""
    if body is None or body is True:
        return {}
    m = r.mapping(body, path)
    if m is not None:
        r.check_keys(m, path, fmt.CONDITION_FIELDS[kind])
    return m


def _read_all(r: Reader, m: dict, path: tuple, spec: dict) -> dict:
    """Every scalar field of ``spec`` read from ``m`` (defaults filled in)."""
    return {name: r.field(m, path, f) for name, f in spec.items()}


def _pred_simple(r: Reader, body: Any, path: tuple, kind: str) -> Predicate | None:
    m = _body(r, body, path, kind)
    if m is None:
        return None
    return Predicate(kind, _read_all(r, m, path, fmt.CONDITION_FIELDS[kind]), r.mark(path), path)


def _pred_range(r: Reader, body: Any, path: tuple, kind: str) -> Predicate | None:
    m = _body(r, body, path, kind)
    if m is None:
        return None
    lo = r.field(m, path, fmt.CONDITION_FIELDS[kind]["min"])
    hi = r.field(m, path, fmt.CONDITION_FIELDS[kind]["max"])
    if "min" not in m and "max" not in m:
        r.error(path, f"`{kind}` needs `min`, `max` or both")
    elif lo is not None and hi is not None and not lo < hi:
        r.error(path + ("max",), f"max {hi} must be above min {lo}")
    return Predicate(kind, {"min": lo, "max": hi}, r.mark(path), path)


def _pred_blackboard(r: Reader, body: Any, path: tuple, kind: str) -> Predicate | None:
    m = _body(r, body, path, kind)
    if m is None:
        return None
    key = r.field(m, path, fmt.CONDITION_FIELDS[kind]["key"])
    ops = [k for k in COMPARISONS if k in m]
    if len(ops) != 1:
        r.error(path, f"`blackboard` needs exactly one comparison (one of: {', '.join(COMPARISONS)}), got {len(ops)}")
        return Predicate(kind, {"key": key, "op": None, "value": None}, r.mark(path), path)
    op = ops[0]
    value = m[op]
    if op == "is_set" and not isinstance(value, bool):
        r.error(path + (op,), f"expected true or false, got {r.got(path + (op,), value)}")
    elif op in ("below", "above", "at_most", "at_least") and not is_number(value):
        r.error(path + (op,), f"expected a number, got {r.got(path + (op,), value)}")
    elif op in ("equals", "not_equals") and not (is_number(value) or isinstance(value, (str, bool))):
        r.error(path + (op,), f"expected a number, string or boolean, got {type_name(value)}")
    return Predicate(kind, {"key": key, "op": op, "value": value}, r.mark(path), path)


_PREDICATE_PARSERS: dict[str, Callable[[Reader, Any, tuple, str], Predicate | None]] = {
    "detected": _pred_simple,
    "grasp_detected": _pred_simple,
    "converged": _pred_simple,
    "depth_m": _pred_range,
    "altitude_m": _pred_range,
    "force_n": _pred_range,
    "blackboard": _pred_blackboard,
}


# --------------------------------------------------------------------------- nodes


def parse_node(r: Reader, value: Any, path: tuple) -> Node | None:
    """One tree node ``{<kind>: <body>}``; None (with issues recorded) if malformed."""
    m = r.mapping(value, path, "a node such as {sequence: {children: [...]}}")
    if m is None:
        return None
    if len(m) != 1:
        keys = ", ".join(f"`{k}`" for k in m)
        r.error(path, f"a node is a mapping with exactly one key, its kind (e.g. `action`), got {keys}")
        return None
    ((kind, body),) = m.items()
    kind = NODE_ALIASES.get(kind, kind)
    kpath = path + (next(iter(m)),)
    if kind not in NODE_KINDS:
        choices = NODE_KINDS + tuple(NODE_ALIASES)
        r.key_error(
            kpath, f"unknown node kind `{kind}`{suggest(str(kind), choices)}; expected one of: {', '.join(choices)}"
        )
        return None
    if kind == "subtree" and isinstance(body, str):
        body = {"use": body}
    if kind == "condition" and isinstance(body, str):  # `condition: converged`
        pred = parse_predicate(r, body, kpath)
        name = f"Check {pred.describe()}" if pred else "Check"
        return Node(kind, name, {"predicate": pred}, (), r.mark(kpath), kpath)
    b = r.mapping(body, kpath, f"the fields of the `{kind}` node (a mapping)")
    if b is None:
        return None
    return _NODE_PARSERS[kind](r, b, kpath, kind)


def _name(r: Reader, b: dict, path: tuple, default: str) -> str:
    return r.field(b, path, fmt.NAME) or default


def _keys(r: Reader, b: dict, path: tuple, kind: str) -> dict:
    """Check ``b``'s keys against the kind's fields; returns the fields."""
    spec = fmt.NODE_FIELDS[kind]
    r.check_keys(b, path, spec)
    return spec


def _children(r: Reader, b: dict, path: tuple) -> tuple[Node, ...]:
    if "children" not in b:
        r.error(path + ("children",), "missing required field `children` (a list of nodes)")
        return ()
    items = b["children"]
    if not isinstance(items, list) or not items:
        r.error(path + ("children",), f"expected a non-empty list of nodes, got {type_name(items)}")
        return ()
    nodes = [parse_node(r, item, path + ("children", i)) for i, item in enumerate(items)]
    return tuple(n for n in nodes if n is not None)


def _child(r: Reader, b: dict, path: tuple) -> tuple[Node, ...]:
    if "child" not in b:
        r.error(path + ("child",), "missing required field `child` (one node)")
        return ()
    node = parse_node(r, b["child"], path + ("child",))
    return (node,) if node is not None else ()


def _node(kind: str, name: str, params: dict, children: tuple, r: Reader, path: tuple) -> Node:
    return Node(kind, name, params, children, r.mark(path), path)


def _composite(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    spec = _keys(r, b, path, kind)
    names = [n for n in spec if n not in ("name", "children")]
    params = {n: r.field(b, path, spec[n]) for n in names}
    return _node(kind, _name(r, b, path, kind.capitalize()), params, _children(r, b, path), r, path)


def _timeout(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    d = r.field(b, path, _keys(r, b, path, kind)["duration_s"])
    return _node(
        kind, _name(r, b, path, f"Timeout {d:g} s" if d else "Timeout"), {"duration_s": d}, _child(r, b, path), r, path
    )


def _retry(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    n = r.field(b, path, _keys(r, b, path, kind)["attempts"])
    return _node(kind, _name(r, b, path, f"Retry up to {n} attempts"), {"attempts": n}, _child(r, b, path), r, path)


def _repeat(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    n = r.field(b, path, _keys(r, b, path, kind)["times"])
    return _node(kind, _name(r, b, path, f"Repeat {n} times"), {"times": n}, _child(r, b, path), r, path)


def _inverter(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    _keys(r, b, path, kind)
    return _node(kind, _name(r, b, path, "Not"), {}, _child(r, b, path), r, path)


def _one_shot(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    on = r.field(b, path, _keys(r, b, path, kind)["on"])
    return _node(kind, _name(r, b, path, "Once"), {"on": on}, _child(r, b, path), r, path)


def _guard(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    _keys(r, b, path, kind)
    pred = None
    if "condition" not in b:
        r.error(path + ("condition",), "missing required field `condition`")
    else:
        pred = parse_predicate(r, b["condition"], path + ("condition",))
    default = f"While {pred.describe()}" if pred else "Guard"
    return _node(kind, _name(r, b, path, default), {"condition": pred}, _child(r, b, path), r, path)


def _goal(r: Reader, value: Any, path: tuple) -> dict | None:
    m = r.mapping(value, path, "a goal mapping with north_m, east_m, down_m or altitude_m, yaw_deg")
    if m is None:
        return None
    r.check_keys(m, path, fmt.GOAL)
    goal = _read_all(r, m, path, fmt.GOAL)
    if "down_m" in m and "altitude_m" in m:
        r.error(path + ("altitude_m",), "give either `down_m` or `altitude_m`, not both")
    return goal


def _targets(r: Reader, value: Any, path: tuple) -> dict:
    m = r.mapping(value, path, "a mapping of targets")
    if m is None:
        return {}
    spec = fmt.TARGETS
    r.check_keys(m, path, spec)
    out: dict[str, Any] = {
        k: r.field(m, path, spec[k])
        for k in ("tolerance_m", "yaw_tolerance_deg", "loop", "tool_goal_from", "camera_target_from")
    }
    out["vehicle_goal"] = None
    out["waypoints"] = None
    if "vehicle_goal" in m and "waypoints" in m:
        r.error(path + ("waypoints",), "give either `vehicle_goal` or `waypoints`, not both")
    if "vehicle_goal" in m:
        out["vehicle_goal"] = _goal(r, m["vehicle_goal"], path + ("vehicle_goal",))
    if "waypoints" in m:
        wps = m["waypoints"]
        if not isinstance(wps, list) or not wps:
            r.error(path + ("waypoints",), f"expected a non-empty list of goals, got {type_name(wps)}")
        else:
            goals = [_goal(r, w, path + ("waypoints", i)) for i, w in enumerate(wps)]
            out["waypoints"] = [g for g in goals if g is not None]
    return out


def _track(r: Reader, value: Any, path: tuple) -> dict | None:
    m = r.mapping(value, path)
    if m is None:
        return None
    r.check_keys(m, path, fmt.TRACK)
    return _read_all(r, m, path, fmt.TRACK)


def _action(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    spec = _keys(r, b, path, kind)
    run = r.field(b, path, spec["run"])
    params = {
        "run": run,
        "targets": _targets(r, b["targets"], path + ("targets",)) if "targets" in b else {},
        "until": parse_predicate(r, b["until"], path + ("until",)) if "until" in b else None,
        "timeout_s": r.field(b, path, spec["timeout_s"]),
        "track_detection": _track(r, b["track_detection"], path + ("track_detection",))
        if "track_detection" in b
        else None,
    }
    return _node(kind, _name(r, b, path, f"Action {run}"), params, (), r, path)


def _condition(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    rest = {k: v for k, v in b.items() if k != "name"}
    pred = None
    if len(rest) != 1:
        r.error(path, f"a condition has a `name` (optional) and exactly one of: {', '.join(PREDICATE_KINDS)}")
    else:
        pred = parse_predicate(r, rest, path)
    name = _name(r, b, path, f"Check {pred.describe()}" if pred else "Check")
    return _node(kind, name, {"predicate": pred}, (), r, path)


def _gripper(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    spec = _keys(r, b, path, kind)
    cmd = r.field(b, path, spec["command"])
    params = {
        "command": cmd,
        "shape": r.string(b, path, "shape", default=MISSING if cmd == "preshape" else None),
        "current_limit_a": r.number(
            b, path, "current_limit_a", default=MISSING if cmd == "close" else None, lo=0.0, lo_open=True
        ),
        "timeout_s": r.field(b, path, spec["timeout_s"]),
        "wait": r.field(b, path, spec["wait"]),
    }
    if cmd != "preshape" and "shape" in b:
        r.error(path + ("shape",), "`shape` is only used with `command: preshape`")
    if cmd != "close" and "current_limit_a" in b:
        r.error(path + ("current_limit_a",), "`current_limit_a` is only used with `command: close`")
    return _node(kind, _name(r, b, path, f"Gripper {cmd}"), params, (), r, path)


def _wait(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    d = r.field(b, path, _keys(r, b, path, kind)["duration_s"])
    return _node(kind, _name(r, b, path, f"Wait {d:g} s" if d is not None else "Wait"), {"duration_s": d}, (), r, path)


def _set(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    spec = _keys(r, b, path, kind)
    key = r.field(b, path, spec["key"])
    if ("value" in b) == ("add" in b):
        r.error(path, "`set` needs exactly one of `value` (write it) or `add` (add a number to it)")
    value, add = b.get("value"), None
    if "value" in b and (value is None or isinstance(value, (dict, list))):
        r.error(path + ("value",), f"expected a number, string or boolean, got {type_name(value)}")
    if "add" in b:
        add = r.number(b, path, "add")
    default = f"Add {add:g} to {key}" if add is not None else f"Set {key}"
    return _node(kind, _name(r, b, path, default), {"key": key, "value": value, "add": add}, (), r, path)


def _log(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    spec = _keys(r, b, path, kind)
    params = {"message": r.field(b, path, spec["message"]), "level": r.field(b, path, spec["level"])}
    msg = params["message"] or ""
    default = f"Log: {msg[:40]}{'...' if len(msg) > 40 else ''}" if msg else "Log"
    return _node(kind, _name(r, b, path, default), params, (), r, path)


def _subtree(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    use = r.field(b, path, _keys(r, b, path, kind)["use"])
    return _node(kind, _name(r, b, path, f"{use}" if use else "Subtree"), {"use": use}, (), r, path)


def _handback(r: Reader, value: Any, path: tuple) -> dict[str, Any]:
    """How the operator hands back: ``{button, service, until}`` (default: button or service)."""
    if value is None:
        return {"button": True, "service": True, "until": None}
    m = r.mapping(value, path, "a mapping such as {button: true, until: {detected: {min_confidence: 0.6}}}")
    if m is None:
        return {"button": True, "service": True, "until": None}
    r.check_keys(m, path, fmt.HANDBACK)
    out = {
        "button": r.field(m, path, fmt.HANDBACK["button"]),
        "service": r.field(m, path, fmt.HANDBACK["service"]),
        "until": parse_predicate(r, m["until"], path + ("until",)) if "until" in m else None,
    }
    if not out["button"] and not out["service"] and "until" not in m:
        r.error(path, "the operator could never hand back: keep `button` or `service`, or give `until`")
    return out


def _teleop(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    spec = _keys(r, b, path, kind)
    params: dict[str, Any] = {
        k: r.field(b, path, spec[k])
        for k in ("modes", "start_mode", "inputs", "frame", "deadman_s", "goal_max_age_s", "timeout_s")
    }
    modes, start = params["modes"], params["start_mode"]
    if modes and start and start not in modes:
        r.error(path + ("start_mode",), f"start_mode `{start}` is not one of `modes`: {', '.join(modes)}")
    params["handback"] = _handback(r, b.get("handback"), path + ("handback",))
    default = f"Operator control ({', '.join(modes)})" if modes else "Operator control"
    return _node(kind, _name(r, b, path, default), params, (), r, path)


_NODE_PARSERS: dict[str, Callable[[Reader, dict, tuple, str], Node]] = {
    "sequence": _composite,
    "selector": _composite,
    "parallel": _composite,
    "timeout": _timeout,
    "retry": _retry,
    "repeat": _repeat,
    "inverter": _inverter,
    "guard": _guard,
    "one_shot": _one_shot,
    "action": _action,
    "condition": _condition,
    "gripper": _gripper,
    "wait": _wait,
    "set": _set,
    "log": _log,
    "subtree": _subtree,
    "teleop": _teleop,
}
