"""Topics and JSON schemas of the input record (``/replay/header``, ``/replay/steps``).

Registered with :mod:`mission.logs.channels` when imported (every log written
after that has them; the run's entry points import the input record). The
schemas load in Foxglove Studio 1.48: one JSON type per field (no unions such
as ``["number", "null"]``), ``properties`` on every object. A value that may be
absent (``body_velocity`` without a DVL, ``altitude`` unknown) is left out of
its record; a non-finite number is written as ``null`` and named in the
record's ``nonfinite`` list (``"attitude.0=nan"``), so NaN and the infinities
come back exactly. Times are backend clock seconds; vectors follow
:mod:`hal.interfaces` (NED world, FRD body, SI units, radians).
"""

from __future__ import annotations

from mission.logs.channels import register_channels

#: Version of the record layout written by :mod:`mission.replay.record`.
FORMAT = 1

HEADER_TOPIC = "/replay/header"
STEP_TOPIC = "/replay/steps"
#: Backend steps per ``/replay/steps`` message (one MCAP message per step would
#: cost more than the records themselves; 10 = one tree tick at the usual rates).
STEPS_PER_MESSAGE = 10

_NUM = {"type": "number"}
_INT = {"type": "integer"}
_STR = {"type": "string"}
_BOOL = {"type": "boolean"}
_VEC = {"type": "array", "items": {"type": "number"}}
_STRS = {"type": "array", "items": _STR}
_T = {"type": "number", "description": "backend clock, s"}

_READ = {
    "type": "object",
    "description": "What one device call returned. `call` names it (`clock.now`, `vehicle.navigation`, "
    "`arm.joint_state`, `gripper.state`, `wrench_sensor.wrench`, `detector.latest`, `<role>.health`, "
    "`vehicle.armed`, `operator.drain`, `pylog.drain`, `backend.open`, and a driver's own methods the "
    "supervisor calls, such as `arm.reset_faults`); `k` is the call's index among the calls of the "
    "same name in this step. A call is written only when its result differs from the previous one of "
    "the same name: a replayed call gets the last record at or before its (step, k).",
    "properties": {
        "call": _STR,
        "k": _INT,
        "t": _T,
        "position": _VEC,
        "attitude": _VEC,
        "body_velocity": _VEC,
        "velocity_t": _NUM,
        "depth": _NUM,
        "altitude": _NUM,
        "velocity": _VEC,
        "current": _VEC,
        "fault": _STR,
        "positions": _VEC,
        "currents": _VEC,
        "motion": _STR,
        "force": _VEC,
        "torque": _VEC,
        "pose": {"type": "array", "items": _NUM, "description": "grasp frame in the vehicle frame, 4x4 row major"},
        "confidence": _NUM,
        "details": {"type": "string", "description": "what the vision system saw, JSON text"},
        "none": {"type": "boolean", "description": "the call returned None (no reading yet)"},
        "state": _STR,
        "detail": _STR,
        "info": {"type": "string", "description": "health diagnostics, JSON text"},
        "value": _BOOL,
        "commands": {"type": "array", "items": {"type": "object", "properties": {"command": _STR, "source": _STR}}},
        "records": {
            "type": "array",
            "description": "Python logging records (drivers' warnings) the supervisor turned into events",
            "items": {"type": "object", "properties": {"logger": _STR, "level": _STR, "text": _STR}},
        },
        "args": {"type": "string", "description": "a driver method's arguments, JSON text"},
        "result": {"type": "string", "description": "a driver method's result, JSON text"},
        "error_type": {"type": "string", "description": "the call raised this exception type"},
        "error": {"type": "string", "description": "the exception's message"},
        "error_module": {"type": "string", "description": "the exception's module, when not a builtin"},
        "nonfinite": {
            "type": "array",
            "items": _STR,
            "description": "fields written as null: `field.index=nan|inf|-inf`",
        },
    },
}

_COMMAND = {
    "type": "object",
    "description": "One command sent to a device, in call order: `call` (`vehicle.command_body_velocity`, "
    "`arm.command_joint_velocity`, `gripper.close`, `vehicle.arm`, `<role>.safe_stop`, ...), its numeric "
    "arguments (`values`: m/s, rad/s, A) or text argument, and the exception it raised, if any.",
    "properties": {
        "call": _STR,
        "values": _VEC,
        "text": _STR,
        "error_type": _STR,
        "error": _STR,
        "error_module": _STR,
        "nonfinite": _STRS,
    },
}

#: topic -> (schema name, JSON schema), merged into :data:`mission.logs.channels.CHANNELS`.
REPLAY_CHANNELS: dict[str, tuple[str, dict]] = {
    HEADER_TOPIC: (
        "maris.ReplayHeader",
        {
            "title": "ReplayHeader",
            "description": "The devices behind the run (for a replay backend to stand in for them), written once "
            "before anything else.",
            "type": "object",
            "properties": {
                "t": _T,
                "format": _INT,
                "backend": _STR,
                "realtime": _BOOL,
                "code": {"type": "string", "description": "fingerprint of the supervisor's Python source"},
                "mission_file": {"type": "string", "description": "the mission file, absolute path"},
                "devices": {
                    "type": "array",
                    "items": {
                        "type": "object",
                        "properties": {
                            "role": _STR,
                            "name": _STR,
                            "kind": _STR,
                            "extras": {
                                "type": "array",
                                "items": _STR,
                                "description": "the driver's own public methods (beyond hal.interfaces)",
                            },
                        },
                    },
                },
                "joint_names": _STRS,
                "actuated_dofs": {"type": "array", "items": _BOOL},
                "preshapes": _STRS,
            },
            "required": ["t", "format"],
        },
    ),
    STEP_TOPIC: (
        "maris.ReplaySteps",
        {
            "title": "ReplaySteps",
            "description": f"Backend steps in order ({STEPS_PER_MESSAGE} per message): for each, every input the "
            "supervisor consumed during it (between two `advance(dt)` calls) and every command it sent.",
            "type": "object",
            "properties": {
                "t": _T,
                "steps": {
                    "type": "array",
                    "items": {
                        "type": "object",
                        "properties": {
                            "step": {"type": "integer", "description": "advances before this step"},
                            "t": {"type": "number", "description": "last clock reading up to the step's end, s"},
                            "dt": {
                                "type": "number",
                                "description": "the advance that ended the step, s (absent: the last step)",
                            },
                            "reads": {"type": "array", "items": _READ},
                            "commands": {"type": "array", "items": _COMMAND},
                        },
                    },
                },
            },
            "required": ["t", "steps"],
        },
    ),
}


def record_steps(log: object) -> list[dict]:
    """Every step record of a log (anything with ``messages(topic)``), in order."""
    return [s for m in log.messages(STEP_TOPIC) for s in m.get("steps", ())]  # type: ignore[attr-defined]


register_channels(REPLAY_CHANNELS)
