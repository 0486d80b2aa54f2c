"""The topics of a run log and their JSON schemas.

Every message is a JSON object with a ``t`` field (backend clock, s). Schemas are
deliberately permissive (``additionalProperties`` allowed) so that a newer
writer stays readable by an older Foxglove layout; they document the fields the
log tools rely on. Vectors follow :mod:`hal.interfaces`: body velocity
``[u v w p q r]`` in the vehicle frame (m/s, rad/s), joints in rad and rad/s.
"""

from __future__ import annotations

from typing import Any

_NUM = {"type": "number"}
_VEC = {"type": "array", "items": {"type": ["number", "null"]}}
_OPT_VEC = {"type": ["array", "null"], "items": {"type": ["number", "null"]}}
_STR = {"type": "string"}


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
    "/run/config": ("maris.RunConfig", _obj(
        "RunConfig", "How the run was started: mission, scenario, seed, controller settings, rates.",
        {"mission_path": _STR, "mission_name": _STR, "scenario": {"type": ["string", "null"]},
         "seed": {"type": ["integer", "null"]}, "realtime": {"type": "boolean"},
         "rates_hz": {"type": "object"}, "controller": {"type": "object"}, "safety": {"type": "object"}})),
    "/run/source": ("maris.SourceFile", _obj(
        "SourceFile", "A user-written file used by the run, verbatim (mission, HAL config, scenario).",
        {"role": _STR, "path": _STR, "text": _STR})),
    "/supervisor/state": ("maris.SupervisorState", _obj(
        "SupervisorState", "Lifecycle transition of the supervisor state machine.",
        {"state": _STR, "previous": _STR, "trigger": _STR, "reason": _STR})),
    "/tree": ("maris.TreeSnapshot", _obj(
        "TreeSnapshot", "Behaviour tree status, written when any node's status changes.",
        {"nodes": {"type": "array", "items": {"type": "object", "properties": {
            "name": _STR, "type": _STR, "status": _STR, "depth": {"type": "integer"}}}},
         "tip": {"type": ["string", "null"]}, "root_status": _STR})),
    "/events": ("maris.Event", _obj(
        "Event", "Mission events, faults and operator commands.",
        {"kind": _STR, "level": {"type": "string", "enum": ["info", "warning", "fault"]},
         "message": _STR, "fields": {"type": "object"}})),
    "/kcl": ("maris.KclState", _obj(
        "KclState", "Kinematic control layer telemetry: current action, transition progress and, "
        "per task, activation, error and reference rate.",
        {"action": {"type": ["string", "null"]}, "transition": {"type": ["number", "null"]},
         "tasks": {"type": "object"}, "fault": {}})),
    "/vehicle/navigation": ("maris.Navigation", _obj(
        "Navigation", "Vehicle navigation: NED position (m), roll/pitch/yaw (rad), body velocity "
        "[u v w p q r] (m/s, rad/s, vehicle frame), depth and altitude (m).",
        {"position": _VEC, "attitude": _VEC, "body_velocity": _OPT_VEC, "depth": _NUM,
         "altitude": {"type": ["number", "null"]}})),
    "/vehicle/command": ("maris.VehicleCommand", _obj(
        "VehicleCommand", "Commanded body velocity [u v w p q r] (m/s, rad/s, vehicle frame).",
        {"body_velocity": _VEC})),
    "/arm/state": ("maris.JointState", _obj(
        "JointState", "Arm joints: position (rad), velocity (rad/s), current (A).",
        {"position": _VEC, "velocity": _VEC, "current": _VEC, "fault": {"type": ["string", "null"]}})),
    "/arm/command": ("maris.JointCommand", _obj(
        "JointCommand", "Joint velocity references (rad/s).", {"velocity": _VEC})),
    "/gripper/state": ("maris.GripperState", _obj(
        "GripperState", "Gripper motor groups: positions (rad), currents (A), motion.",
        {"positions": _VEC, "currents": _VEC, "motion": _STR, "fault": {"type": ["string", "null"]}})),
    "/detector": ("maris.Detection", _obj(
        "Detection", "Latest target detection: grasp frame pose in the vehicle frame (4x4, row major).",
        {"image_t": _NUM, "pose": _VEC, "confidence": _NUM})),
    "/wrench": ("maris.Wrench", _obj(
        "Wrench", "Wrist force (N) and torque (N m) in the sensor frame.",
        {"force": _VEC, "torque": _VEC, "reading_t": _NUM})),
    "/devices/health": ("maris.DeviceHealth", _obj(
        "DeviceHealth", "Health of every device (ok, degraded, fault, missing), written when one changes.",
        {"devices": {"type": "object"}})),
    "/blackboard": ("maris.Blackboard", _obj(
        "Blackboard", "The mission's typed blackboard keys (poses as 4x4 nested lists, world NED, m), "
        "written when a value changes.", {"values": {"type": "object"}})),
    "/safety/margins": ("maris.SafetyMargins", _obj(
        "SafetyMargins", "Distance to each safety limit (positive = inside), in the limit's unit.",
        {"margins": {"type": "object"}})),
    "/ground_truth": ("maris.GroundTruth", _obj(
        "GroundTruth", "Simulator truth (absent on real hardware): tool-to-target distance (m), grasp.",
        {"tool_to_target_m": {"type": ["number", "null"]}, "grasp": {"type": ["string", "null"]}})),
    "/run/result": ("maris.RunResult", _obj(
        "RunResult", "Outcome of the run, written once at the end.",
        {"outcome": _STR, "duration_s": _NUM, "failure_cause": {"type": ["string", "null"]},
         "grasp": {"type": ["string", "null"]}, "metrics": {"type": "object"}})),
}


# The vision system's channels (camera frames, annotations, detections): mission/logs/vision_channels.py.
from mission.logs.vision_channels import VISION_CHANNELS  # noqa: E402

CHANNELS.update(VISION_CHANNELS)


def seconds_to_ns(t: float) -> int:
    """Backend clock time (s) to an MCAP timestamp (ns, clamped at 0)."""
    return max(0, int(round(t * 1e9)))
