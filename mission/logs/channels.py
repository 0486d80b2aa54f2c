"""The topics of a run log and their JSON schemas (the ``maris.*`` channels).

Every message is a JSON object with a ``t`` field (backend clock, s). Schemas
document the fields the log tools rely on and stay permissive
(``additionalProperties`` allowed) so a newer writer stays readable by an older
layout. Vectors follow :mod:`hal.interfaces`: body velocity ``[u v w p q r]`` in
the vehicle frame (m/s, rad/s), joints in rad and rad/s.

The schemas are written in the subset of JSON Schema that Foxglove's parser
accepts (checked in Foxglove Studio 1.48): every field has exactly one ``type``
(no unions such as ``["number", "null"]``; a value that may be missing is
declared with its type and written as ``null``), every ``object`` has
``properties`` (free-form maps declare ``{}``), every ``array`` has typed
``items`` (no arrays of arrays). A schema breaking these rules makes the viewer
drop the whole channel; ``tests/logs`` checks every schema here against them.

The Foxglove well-known channels (3D transforms, scene, log, poses, named
joints) are in :mod:`mission.logs.wellknown`. Packages built on the logs add
their own channels with :func:`register_channels` (the replay's input record).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from mission.logs.vision_channels import VISION_CHANNELS

_NUM = {"type": "number"}
_INT = {"type": "integer"}
_BOOL = {"type": "boolean"}
_STR = {"type": "string"}
_VEC = {"type": "array", "items": {"type": "number"}}


def _num(description: str) -> dict:
    return {"type": "number", "description": description}


def _str(description: str) -> dict:
    return {"type": "string", "description": description}


def _vec(description: str) -> dict:
    return {"type": "array", "items": {"type": "number"}, "description": description}


def _map(description: str, props: dict[str, Any] | None = None) -> dict:
    """An object whose keys are data (task names, device roles...): free-form."""
    return {"type": "object", "properties": dict(props or {}), "description": description}


def _obj(title: str, description: str, props: dict[str, Any], required: tuple[str, ...] = ("t",)) -> dict:
    return {
        "title": title,
        "description": description,
        "type": "object",
        "properties": {"t": {"type": "number", "description": "backend clock, s"}, **props},
        "required": list(required),
    }


#: topic -> (schema name, JSON schema)
CHANNELS: dict[str, tuple[str, dict]] = {
    "/run/config": (
        "maris.RunConfig",
        _obj(
            "RunConfig",
            "How the run was started: mission, scenario, seed, controller settings, rates.",
            {
                "mission_path": _STR,
                "mission_name": _STR,
                "scenario": _str("scenario name; null on real hardware"),
                "seed": {"type": "integer", "description": "null on real hardware"},
                "realtime": _BOOL,
                "rates_hz": _map("tree, vehicle and arm rates (Hz)"),
                "controller": _map("KCL configuration"),
                "safety": _map("safety envelope of the mission"),
                "overrides": _map("scenario overrides"),
                "supervisor": _map("supervisor options"),
                "joint_names": {"type": "array", "items": _STR},
                "actuated_dofs": {"type": "array", "items": _BOOL},
            },
        ),
    ),
    "/run/source": (
        "maris.SourceFile",
        _obj(
            "SourceFile",
            "A user-written file used by the run, verbatim (mission, HAL config, scenario).",
            {"role": _STR, "path": _STR, "text": _STR},
        ),
    ),
    "/supervisor/state": (
        "maris.SupervisorState",
        _obj(
            "SupervisorState",
            "Lifecycle transition of the supervisor state machine.",
            {"state": _STR, "previous": _STR, "trigger": _STR, "reason": _STR},
        ),
    ),
    "/tree": (
        "maris.TreeSnapshot",
        _obj(
            "TreeSnapshot",
            "Behaviour tree status, written when any node's status changes. `rows` is the "
            "tree drawn in py_trees' text style, one node per row (for Foxglove's Table panel).",
            {
                "nodes": {
                    "type": "array",
                    "items": {
                        "type": "object",
                        "properties": {
                            "name": _STR,
                            "type": _STR,
                            "kind": _STR,
                            "status": _STR,
                            "depth": _INT,
                            "message": _STR,
                        },
                    },
                },
                "tip": _str("name of the running leaf; null when none"),
                "root_status": _STR,
                "rows": {"type": "array", "items": {"type": "object", "properties": {"node": _STR}}},
            },
        ),
    ),
    "/events": (
        "maris.Event",
        _obj(
            "Event",
            "Mission events, faults and operator commands (also on /log as foxglove.Log).",
            {
                "kind": _STR,
                "level": {"type": "string", "enum": ["info", "warning", "fault"]},
                "message": _STR,
                "fields": _map("event details"),
            },
        ),
    ),
    "/kcl": (
        "maris.KclState",
        _obj(
            "KclState",
            "Kinematic control layer telemetry: current action, transition progress, references and, "
            "per task, action factor a_p, activation, error and reference rate.",
            {
                "action": _str("current action; null when none"),
                "previous_action": _STR,
                "transition_progress": _num("0..1 through the action transition"),
                "stopped": _BOOL,
                "fault": _BOOL,
                "fault_reason": _STR,
                "fault_count": _INT,
                "compensation": _BOOL,
                "vehicle_reference": _vec("TPIK 1 body velocity reference [u v w p q r]"),
                "joint_reference": _vec("TPIK 2 joint velocity references (rad/s)"),
                "filtered_velocity": _vec("filtered measured body velocity; null without DVL"),
                "tpik2_vehicle_velocity": _vec("vehicle velocity the arm compensated"),
                "convergence": _num("largest goal-task error norm of the action"),
                "tasks": _map("per task: a_p, activation[], error[], reference[], commanded_rate[]"),
                "limited": _map(
                    "tasks of the action moved at < 90 % of their reference by the last commands: "
                    "ratio, and the active inequality tasks above them (by)"
                ),
            },
        ),
    ),
    "/vehicle/navigation": (
        "maris.Navigation",
        _obj(
            "Navigation",
            "Vehicle navigation: NED position (m), roll/pitch/yaw (rad), body velocity "
            "[u v w p q r] (m/s, rad/s, vehicle frame; null without DVL), depth and altitude (m; null unknown).",
            {
                "position": _VEC,
                "attitude": _VEC,
                "body_velocity": _VEC,
                "velocity_t": _NUM,
                "nav_t": _NUM,
                "depth": _NUM,
                "altitude": _NUM,
            },
        ),
    ),
    "/vehicle/command": (
        "maris.VehicleCommand",
        _obj(
            "VehicleCommand",
            "Commanded body velocity [u v w p q r] (m/s, rad/s, vehicle frame).",
            {"body_velocity": _VEC},
        ),
    ),
    "/arm/state": (
        "maris.JointState",
        _obj(
            "JointState",
            "Arm joints: position (rad), velocity (rad/s), current (A); named copy on /arm/joints.",
            {
                "position": _VEC,
                "velocity": _VEC,
                "current": _VEC,
                "fault": _str("null when healthy"),
                "reading_t": _NUM,
            },
        ),
    ),
    "/arm/command": (
        "maris.JointCommand",
        _obj("JointCommand", "Joint velocity references (rad/s).", {"velocity": _VEC}),
    ),
    "/gripper/state": (
        "maris.GripperState",
        _obj(
            "GripperState",
            "Gripper motor groups: positions (rad), currents (A), motion.",
            {
                "positions": _VEC,
                "currents": _VEC,
                "motion": _STR,
                "fault": _str("null when healthy"),
                "reading_t": _NUM,
            },
        ),
    ),
    "/detector": (
        "maris.Detection",
        _obj(
            "Detection",
            "Latest target detection: grasp frame pose in the vehicle frame (4x4, row major).",
            {"image_t": _NUM, "pose": _VEC, "confidence": _NUM},
        ),
    ),
    "/wrench": (
        "maris.Wrench",
        _obj(
            "Wrench",
            "Wrist force (N) and torque (N m) in the sensor frame.",
            {"force": _VEC, "torque": _VEC, "reading_t": _NUM},
        ),
    ),
    "/devices/health": (
        "maris.DeviceHealth",
        _obj(
            "DeviceHealth",
            "Health of every device (ok, degraded, fault, missing), written when one changes.",
            {"devices": _map("role -> {state, detail}")},
        ),
    ),
    "/blackboard": (
        "maris.Blackboard",
        _obj(
            "Blackboard",
            "The mission's typed blackboard keys (poses as 4x4 nested lists, world NED, m), "
            "written when a value changes.",
            {"values": _map("key -> value")},
        ),
    ),
    "/safety/margins": (
        "maris.SafetyMargins",
        _obj(
            "SafetyMargins",
            "Distance to each safety limit (positive = inside), in the limit's unit.",
            {"margins": _map("limit -> margin")},
        ),
    ),
    "/ground_truth": (
        "maris.GroundTruth",
        _obj(
            "GroundTruth",
            "Simulator truth (absent on real hardware): tool-to-target distance (m), grasp, "
            "vehicle, tool and pipe poses.",
            {
                "tool_to_target_m": _NUM,
                "tool_axis_error_rad": _NUM,
                "grasp": _STR,
                "vehicle_speed": _NUM,
                "vehicle_rate": _NUM,
                "vehicle": _map("eta, body_velocity, commanded_velocity"),
                "tool": _map("position, rpy"),
                "pipe": _map("centre/grasp position and rpy"),
                "vision": _map("what the last image saw"),
            },
        ),
    ),
    "/operator/teleop": (
        "maris.Teleop",
        _obj(
            "Teleop",
            "Who has control, at each tree tick while a teleop node runs (then one `autonomy` message): "
            "the mode, the input whose command moves the system, the command (velocity modes: m/s, "
            "rad/s) or goal (world NED, m; a vehicle goal with its heading, rad), and the safety tasks "
            "holding the operator's task back (from the controller's `limited`).",
            {
                "control": _str("operator or autonomy"),
                "node": _str("the teleop node"),
                "mode": _str("tool_velocity, vehicle_velocity, vehicle_goal, tool_goal, point_at"),
                "frame": _str("axes of the tool jog: vehicle or world"),
                "action": _str("the KCL action running"),
                "input": _str("the operator input driving (null: none)"),
                "command": _vec("the velocity command applied (zero: dead-man)"),
                "goal": _vec("the goal taken (world NED)"),
                "limited_by": {"type": "array", "items": _STR, "description": "safety tasks holding it back"},
                "limited": _map("operator task -> {ratio, by}"),
                "dropped": {"type": "integer", "description": "commands dropped as too old so far"},
            },
        ),
    ),
    "/run/result": (
        "maris.RunResult",
        _obj(
            "RunResult",
            "Outcome of the run, written once at the end.",
            {
                "outcome": _STR,
                "duration_s": _NUM,
                "failure_cause": _str("null on success"),
                "grasp": _STR,
                "metrics": _map("figures of the run"),
            },
        ),
    ),
}

# The vision system's channels (camera frames, annotations, detections): mission/logs/vision_channels.py.
CHANNELS.update(VISION_CHANNELS)


def register_channels(table: Mapping[str, tuple[str, dict]]) -> None:
    """Add the channels of a package built on the logs to every log written from now on:
    the input record of ``maris log replay`` (:mod:`mission.replay.schema` registers its
    topics when imported). A topic registered again must keep its schema."""
    for topic, channel in table.items():
        known = CHANNELS.get(topic)
        if known is not None and known != channel:
            raise ValueError(f"log channel {topic} registered twice with different schemas")
        CHANNELS[topic] = channel


def seconds_to_ns(t: float) -> int:
    """Backend clock time (s) to an MCAP timestamp (ns, clamped at 0)."""
    return max(0, int(round(t * 1e9)))


def schema_problems(schema: dict, path: str = "") -> list[str]:
    """Why Foxglove's JSON-schema parser would reject ``schema`` (empty: it accepts it).

    The rules of the parser in Foxglove Studio 1.48: an ``object`` needs
    ``properties``; every property needs one ``type`` among boolean, string,
    number, integer, object, array; an ``array`` needs ``items`` of one such
    type other than array."""
    problems: list[str] = []
    if schema.get("type") != "object":
        return [f"{path or '<root>'}: expected type object, got {schema.get('type')!r}"]
    props = schema.get("properties")
    if not isinstance(props, dict):
        return [f"{path or '<root>'}: object without properties"]
    for name, sub in props.items():
        where = f"{path}.{name}" if path else name
        kind = sub.get("type") if isinstance(sub, dict) else None
        if kind == "object":
            problems += schema_problems(sub, where)
        elif kind == "array":
            items = sub.get("items")
            ikind = items.get("type") if isinstance(items, dict) else None
            if ikind == "object":
                problems += schema_problems(items, where + "[]")
            elif ikind not in ("boolean", "string", "number", "integer"):
                problems.append(f"{where}: array items of type {ikind!r}")
        elif kind not in ("boolean", "string", "number", "integer"):
            problems.append(f"{where}: type {kind!r}")
    return problems
