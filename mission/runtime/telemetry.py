"""Readings, tree state and KCL telemetry as JSON-able log messages
(the schemas are in :mod:`mission.logs.channels`). Pure functions."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from hal.interfaces import Detection, GripperState, JointState, NavigationState
from mission.logs.treeview import node_kind


def tree_walk(root: Any) -> list[tuple[Any, int]]:
    """Pre-order ``(node, depth)`` of every node of a py_trees tree (children, and the
    decorated child of a decorator)."""
    out: list[tuple[Any, int]] = []
    stack = [(root, 0)]
    while stack:
        node, depth = stack.pop()
        out.append((node, depth))
        for child in reversed(getattr(node, "children", []) or []):
            stack.append((child, depth + 1))
        decorated = getattr(node, "decorated", None)
        if decorated is not None and not getattr(node, "children", None):
            stack.append((decorated, depth + 1))
    return out


def tree_nodes(root: Any, walk: list[tuple[Any, int]] | None = None) -> list[dict]:
    """Pre-order list of ``{name, type, kind, status, depth, message}`` for every node
    of a py_trees tree (``kind``: see :func:`mission.logs.treeview.node_kind`;
    ``message``: the node's feedback message). ``walk``: :func:`tree_walk` of ``root``
    if the caller keeps it."""

    return [
        {
            "name": node.name,
            "type": type(node).__name__,
            "kind": node_kind(node),
            "status": node.status.value,
            "depth": depth,
            "message": getattr(node, "feedback_message", "") or "",
        }
        for node, depth in (tree_walk(root) if walk is None else walk)
    ]


def navigation_message(nav: NavigationState) -> dict:
    return {
        "position": nav.position,
        "attitude": nav.attitude,
        "body_velocity": nav.body_velocity,
        "velocity_t": nav.velocity_t,
        "nav_t": nav.t,
        "depth": nav.depth,
        "altitude": nav.altitude,
    }


def joint_message(js: JointState) -> dict:
    return {
        "position": js.position,
        "velocity": js.velocity,
        "current": js.current,
        "fault": js.fault,
        "reading_t": js.t,
    }


def gripper_message(gs: GripperState) -> dict:
    return {
        "positions": gs.positions,
        "currents": gs.currents,
        "motion": gs.motion.value,
        "fault": gs.fault,
        "reading_t": gs.t,
    }


def detection_message(det: Detection) -> dict:
    return {"image_t": det.t, "pose": np.asarray(det.pose).reshape(-1), "confidence": det.confidence}


#: Ground-truth keys not logged every cycle (``events`` grows for the whole run;
#: the supervisor logs new sim events once, on /events).
TRUTH_SKIP = ("events", "t")


#: Value types that :func:`truth_message` keeps as they are without looking further.
_PLAIN = frozenset((str, float, int, bool, dict, list, type(None)))


def _norm3(a: list[float]) -> float:
    x, y, z = a
    return math.sqrt(x * x + y * y + z * z)


def truth_message(truth: dict) -> dict:
    """Ground truth as logged (minus :data:`TRUTH_SKIP`), plus ``vehicle_speed``
    (m/s, linear) and ``vehicle_rate`` (rad/s, angular) when the truth has the
    vehicle's body velocity (``truth["vehicle"]["body_velocity"]``, 6 finite numbers).
    Runs at the ground-truth rate of a logged run: plain floats, no numpy for the
    simulator's lists."""
    msg: dict[str, Any] = {}
    for k, v in truth.items():
        if k in TRUTH_SKIP:
            continue
        tv = type(v)
        if tv is np.ndarray:
            v = v.tolist()
        elif tv not in _PLAIN and hasattr(v, "value") and hasattr(v, "name"):  # enums
            v = v.value
        msg[str(k)] = v
    vehicle = truth.get("vehicle")
    nu = vehicle.get("body_velocity") if isinstance(vehicle, dict) else None
    if nu is not None:
        if type(nu) is list and all(type(x) is float for x in nu):  # the simulator's: taken as it is
            values = nu
        else:
            values = np.asarray(nu, dtype=float).reshape(-1).tolist()
        if len(values) == 6 and all(map(math.isfinite, values)):
            msg["vehicle_speed"] = _norm3(values[:3])
            msg["vehicle_rate"] = _norm3(values[3:])
    d = msg.get("tool_to_target_m")
    if d is not None:
        msg["tool_to_target_m"] = float(d) if math.isfinite(float(d)) else None
    return msg
