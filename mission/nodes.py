"""Parsing of tree nodes and predicates (the ``tree:``, ``subtrees:`` and
``abort:`` sections of a mission file) into :class:`mission.spec.Node`.

A node is written as a one-key mapping ``{<kind>: <body>}``; the body is a
mapping of that kind's fields. ``docs/missions.md`` is the user reference for
every kind; this module is its executable form. Shape and range errors are
collected in the :class:`mission.schema.Reader`; cross references (actions,
subtrees, blackboard keys, devices) are checked later in :mod:`mission.checks`.
"""

from __future__ import annotations

from typing import Any, Callable

from maris_common.yamlsrc import suggest

from .schema import MISSING, Reader, is_number, type_name
from .spec import NODE_ALIASES, NODE_KINDS, PREDICATE_KINDS, Node, Predicate

GRIPPER_COMMANDS = ("open", "close", "preshape")
PARALLEL_POLICIES = ("success_on_all", "success_on_one")
ONE_SHOT_ON = ("success", "success_or_failure")
LOG_LEVELS = ("info", "warning", "fault")  # the run log's event levels
COMPARISONS = ("equals", "not_equals", "below", "above", "at_most", "at_least", "is_set")
GOAL_KEYS = ("north_m", "east_m", "down_m", "altitude_m", "yaw_deg")
TARGET_KEYS = ("vehicle_goal", "waypoints", "tolerance_m", "yaw_tolerance_deg", "loop", "tool_goal_from", "camera_target_from")


# --------------------------------------------------------------------------- predicates


def parse_predicate(r: Reader, value: Any, path: tuple) -> Predicate | None:
    """A predicate: ``{<kind>: <params>}``, or the bare word ``converged`` / ``detected``."""
    if isinstance(value, str):
        if value in ("converged", "detected"):
            return _PREDICATE_PARSERS[value](r, {}, path, value)
        r.error(path, f"unknown condition `{value}`{suggest(value, PREDICATE_KINDS)}; expected one of: {', '.join(PREDICATE_KINDS)}")
        return None
    m = r.mapping(value, path, "a condition mapping such as {detected: {min_confidence: 0.6}}")
    if m is None:
        return None
    if len(m) != 1:
        r.error(path, f"a condition has exactly one kind (one of: {', '.join(PREDICATE_KINDS)}), got {len(m)} keys")
        return None
    ((kind, body),) = m.items()
    if kind not in PREDICATE_KINDS:
        r.key_error(path + (kind,), f"unknown condition `{kind}`{suggest(str(kind), PREDICATE_KINDS)}; expected one of: {', '.join(PREDICATE_KINDS)}")
        return None
    return _PREDICATE_PARSERS[kind](r, body, path + (kind,), kind)


def _body(r: Reader, body: Any, path: tuple, allowed: tuple[str, ...]) -> dict | None:
    """Predicate body: a mapping (None and ``true`` count as empty)."""
    if body is None or body is True:
        return {}
    m = r.mapping(body, path)
    if m is not None:
        r.check_keys(m, path, allowed)
    return m


def _pred_detected(r: Reader, body: Any, path: tuple, kind: str) -> Predicate | None:
    m = _body(r, body, path, ("min_confidence", "max_age_s", "store_as"))
    if m is None:
        return None
    params = {
        "min_confidence": r.number(m, path, "min_confidence", default=0.5, lo=0.0, hi=1.0),
        "max_age_s": r.number(m, path, "max_age_s", default=1.0, lo=0.0, lo_open=True),
        "store_as": r.string(m, path, "store_as", default=None),
    }
    return Predicate(kind, params, r.mark(path), path)


def _pred_grasp(r: Reader, body: Any, path: tuple, kind: str) -> Predicate | None:
    m = _body(r, body, path, ("current_a", "min_groups"))
    if m is None:
        return None
    params = {
        "current_a": r.number(m, path, "current_a", lo=0.0, lo_open=True),
        "min_groups": r.number(m, path, "min_groups", default=1, lo=1, integer=True),
    }
    return Predicate(kind, params, r.mark(path), path)


def _pred_converged(r: Reader, body: Any, path: tuple, kind: str) -> Predicate | None:
    m = _body(r, body, path, ("max_error", "for_s"))
    if m is None:
        return None
    params = {
        "max_error": r.number(m, path, "max_error", default=None, lo=0.0, lo_open=True),
        "for_s": r.number(m, path, "for_s", default=None, lo=0.0),
    }
    return Predicate(kind, params, r.mark(path), path)


def _pred_range(r: Reader, body: Any, path: tuple, kind: str) -> Predicate | None:
    m = _body(r, body, path, ("min", "max"))
    if m is None:
        return None
    lo = r.number(m, path, "min", default=None)
    hi = r.number(m, path, "max", default=None)
    if "min" not in m and "max" not in m:
        r.error(path, f"`{kind}` needs `min`, `max` or both")
    elif lo is not None and hi is not None and not lo < hi:
        r.error(path + ("max",), f"max {hi} must be above min {lo}")
    return Predicate(kind, {"min": lo, "max": hi}, r.mark(path), path)


def _pred_blackboard(r: Reader, body: Any, path: tuple, kind: str) -> Predicate | None:
    m = _body(r, body, path, ("key",) + COMPARISONS)
    if m is None:
        return None
    key = r.string(m, path, "key")
    ops = [k for k in COMPARISONS if k in m]
    if len(ops) != 1:
        r.error(path, f"`blackboard` needs exactly one comparison (one of: {', '.join(COMPARISONS)}), got {len(ops)}")
        return Predicate(kind, {"key": key, "op": None, "value": None}, r.mark(path), path)
    op = ops[0]
    value = m[op]
    if op == "is_set" and not isinstance(value, bool):
        r.error(path + (op,), f"expected true or false, got {type_name(value)} {value!r}")
    elif op in ("below", "above", "at_most", "at_least") and not is_number(value):
        r.error(path + (op,), f"expected a number, got {type_name(value)} {value!r}")
    elif op in ("equals", "not_equals") and not (is_number(value) or isinstance(value, (str, bool))):
        r.error(path + (op,), f"expected a number, string or boolean, got {type_name(value)}")
    return Predicate(kind, {"key": key, "op": op, "value": value}, r.mark(path), path)


_PREDICATE_PARSERS: dict[str, Callable[[Reader, Any, tuple, str], Predicate | None]] = {
    "detected": _pred_detected,
    "grasp_detected": _pred_grasp,
    "converged": _pred_converged,
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
        r.key_error(kpath, f"unknown node kind `{kind}`{suggest(str(kind), choices)}; expected one of: {', '.join(choices)}")
        return None
    if kind == "subtree" and isinstance(body, str):
        body = {"use": body}
    b = r.mapping(body, kpath, f"the fields of the `{kind}` node (a mapping)")
    if b is None:
        return None
    return _NODE_PARSERS[kind](r, b, kpath, kind)


def _name(r: Reader, b: dict, path: tuple, default: str) -> str:
    return r.string(b, path, "name", default=None) or default


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
    allowed = ("name", "children", "memory") if kind != "parallel" else ("name", "children", "policy", "synchronise")
    r.check_keys(b, path, allowed)
    if kind == "parallel":
        params = {
            "policy": r.choice(b, path, "policy", PARALLEL_POLICIES, default="success_on_all"),
            "synchronise": r.boolean(b, path, "synchronise", True),
        }
    else:
        params = {"memory": r.boolean(b, path, "memory", True)}
    return _node(kind, _name(r, b, path, kind.capitalize()), params, _children(r, b, path), r, path)


def _timeout(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    r.check_keys(b, path, ("name", "duration_s", "child"))
    d = r.number(b, path, "duration_s", lo=0.0, lo_open=True)
    return _node(kind, _name(r, b, path, f"Timeout {d:g} s" if d else "Timeout"), {"duration_s": d}, _child(r, b, path), r, path)


def _retry(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    r.check_keys(b, path, ("name", "attempts", "child"))
    n = r.number(b, path, "attempts", lo=1, integer=True)
    return _node(kind, _name(r, b, path, f"Retry up to {n} attempts"), {"attempts": n}, _child(r, b, path), r, path)


def _repeat(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    r.check_keys(b, path, ("name", "times", "child"))
    n = r.number(b, path, "times", lo=1, integer=True)
    return _node(kind, _name(r, b, path, f"Repeat {n} times"), {"times": n}, _child(r, b, path), r, path)


def _inverter(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    r.check_keys(b, path, ("name", "child"))
    return _node(kind, _name(r, b, path, "Not"), {}, _child(r, b, path), r, path)


def _one_shot(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    r.check_keys(b, path, ("name", "on", "child"))
    on = r.choice(b, path, "on", ONE_SHOT_ON, default="success_or_failure")
    return _node(kind, _name(r, b, path, "Once"), {"on": on}, _child(r, b, path), r, path)


def _guard(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    r.check_keys(b, path, ("name", "condition", "child"))
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
    r.check_keys(m, path, GOAL_KEYS)
    goal = {k: r.number(m, path, k, default=None) for k in GOAL_KEYS}
    if goal["altitude_m"] is not None and goal["altitude_m"] <= 0:
        r.error(path + ("altitude_m",), f"{goal['altitude_m']} is out of range: must be > 0")
    if "down_m" in m and "altitude_m" in m:
        r.error(path + ("altitude_m",), "give either `down_m` or `altitude_m`, not both")
    return goal


def _targets(r: Reader, value: Any, path: tuple) -> dict:
    m = r.mapping(value, path, "a mapping of targets")
    if m is None:
        return {}
    r.check_keys(m, path, TARGET_KEYS)
    out: dict[str, Any] = {
        "tolerance_m": r.number(m, path, "tolerance_m", default=0.5, lo=0.0, lo_open=True),
        "yaw_tolerance_deg": r.number(m, path, "yaw_tolerance_deg", default=10.0, lo=0.0, hi=180.0, lo_open=True),
        "loop": r.boolean(m, path, "loop", False),
        "tool_goal_from": r.string(m, path, "tool_goal_from", default=None),
        "camera_target_from": r.string(m, path, "camera_target_from", default=None),
        "vehicle_goal": None,
        "waypoints": None,
    }
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
    r.check_keys(m, path, ("store_as", "min_confidence", "max_age_s"))
    return {
        "store_as": r.string(m, path, "store_as"),
        "min_confidence": r.number(m, path, "min_confidence", default=0.5, lo=0.0, hi=1.0),
        "max_age_s": r.number(m, path, "max_age_s", default=1.0, lo=0.0, lo_open=True),
    }


def _action(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    r.check_keys(b, path, ("name", "run", "targets", "until", "timeout_s", "track_detection"))
    run = r.string(b, path, "run")
    params = {
        "run": run,
        "targets": _targets(r, b["targets"], path + ("targets",)) if "targets" in b else {},
        "until": parse_predicate(r, b["until"], path + ("until",)) if "until" in b else None,
        "timeout_s": r.number(b, path, "timeout_s", default=None, lo=0.0, lo_open=True),
        "track_detection": _track(r, b["track_detection"], path + ("track_detection",)) if "track_detection" in b else None,
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
    r.check_keys(b, path, ("name", "command", "shape", "current_limit_a", "timeout_s", "wait"))
    cmd = r.choice(b, path, "command", GRIPPER_COMMANDS)
    params = {
        "command": cmd,
        "shape": r.string(b, path, "shape", default=MISSING if cmd == "preshape" else None),
        "current_limit_a": r.number(b, path, "current_limit_a", default=MISSING if cmd == "close" else None, lo=0.0, lo_open=True),
        "timeout_s": r.number(b, path, "timeout_s", default=None, lo=0.0, lo_open=True),
        "wait": r.boolean(b, path, "wait", True),
    }
    if cmd != "preshape" and "shape" in b:
        r.error(path + ("shape",), "`shape` is only used with `command: preshape`")
    if cmd != "close" and "current_limit_a" in b:
        r.error(path + ("current_limit_a",), "`current_limit_a` is only used with `command: close`")
    return _node(kind, _name(r, b, path, f"Gripper {cmd}"), params, (), r, path)


def _wait(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    r.check_keys(b, path, ("name", "duration_s"))
    d = r.number(b, path, "duration_s", lo=0.0)
    return _node(kind, _name(r, b, path, f"Wait {d:g} s" if d is not None else "Wait"), {"duration_s": d}, (), r, path)


def _set(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    r.check_keys(b, path, ("name", "key", "value", "add"))
    key = r.string(b, path, "key")
    if ("value" in b) == ("add" in b):
        r.error(path, "`set` needs exactly one of `value` (write it) or `add` (add a number to it)")
    value, add = b.get("value"), None
    if "value" in b and (value is None or isinstance(value, (dict, list))):
        r.error(path + ("value",), f"expected a number, string or boolean, got {type_name(value)}")
    if "add" in b:
        add = r.number(b, path, "add")
    default = (f"Add {add:g} to {key}" if add is not None else f"Set {key}")
    return _node(kind, _name(r, b, path, default), {"key": key, "value": value, "add": add}, (), r, path)


def _log(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    r.check_keys(b, path, ("name", "message", "level"))
    params = {"message": r.string(b, path, "message"), "level": r.choice(b, path, "level", LOG_LEVELS, default="info")}
    msg = params["message"] or ""
    default = f"Log: {msg[:40]}{'...' if len(msg) > 40 else ''}" if msg else "Log"
    return _node(kind, _name(r, b, path, default), params, (), r, path)


def _subtree(r: Reader, b: dict, path: tuple, kind: str) -> Node:
    r.check_keys(b, path, ("name", "use"))
    use = r.string(b, path, "use")
    return _node(kind, _name(r, b, path, f"{use}" if use else "Subtree"), {"use": use}, (), r, path)


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
}
