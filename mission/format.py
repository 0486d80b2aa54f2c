"""The mission format as data: every section, node kind and condition with its
fields (type, range, default, whether required, one line of help).

This table is the single source of the format's shape. The loader reads every
field through it (:meth:`mission.schema.Reader.field`, the allowed keys of
each mapping), and :mod:`mission.jsonschema` generates the JSON Schema that
editors use from it, so the two cannot drift apart. Cross references (action
names, subtrees, blackboard keys, devices) and the safety lint are not shape:
they live in :mod:`mission.checks`. User reference: ``docs/missions.md``.

Field types: ``number`` (finite), ``integer``, ``bool``, ``string``
(non-empty), ``choice`` (one of ``choices``), ``interval`` (``[low, high]``),
``scalar`` (number, string or boolean), and the structured ones the loader
parses with their own code: ``node``, ``nodes``, ``condition``, ``targets``,
``goal``, ``goals``, ``track``, ``safety``, ``rates``, ``geofence``,
``watchdog``, ``blackboard``, ``subtrees``, ``handback``. ``choices``: a
non-empty list of distinct values among ``choices``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .spec import PREDICATE_KINDS

REQUIRED = object()  #: ``default`` of a required field


@dataclass(frozen=True)
class Field:
    """One field of a mapping in a mission file; bounds are inclusive unless ``lo_open``."""

    name: str
    type: str
    doc: str
    default: Any = None
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    choices: tuple[str, ...] = ()
    nullable: bool = False  #: ``null`` is accepted (and means the default / "not set")

    @property
    def required(self) -> bool:
        return self.default is REQUIRED


def fields(*items: Field) -> dict[str, Field]:
    """Fields by name, in the order given (the order of the docs)."""
    return {f.name: f for f in items}


NAME = Field("name", "string", "shown by `maris show` and in the logs; a readable default is made from the fields")

# --------------------------------------------------------------------------- sections

TOP = fields(
    Field("version", "integer", "format version (only 1 exists)", default=1, lo=1, hi=1),
    Field("name", "string", "mission name", default=REQUIRED),
    Field("description", "string", "one line for humans", default=""),
    Field(
        "model",
        "string",
        "URDF of the vehicle-manipulator (relative to the mission file); default: kcl/data/r2_uma.urdf",
    ),
    Field("actions_file", "string", "actions YAML (relative to the mission file); default: kcl/data/actions.yaml"),
    Field("rates", "rates", "loop rates"),
    Field("safety", "safety", "the envelope the supervisor enforces every cycle", default=REQUIRED),
    Field("blackboard", "blackboard", "typed variables shared by the leaves"),
    Field("tree", "node", "the mission", default=REQUIRED),
    Field("subtrees", "subtrees", "reusable trees by name (used by `subtree` leaves)"),
    Field("abort", "node", "run on abort, when the tree fails or on a safety breach", default=REQUIRED),
)

RATES = fields(
    Field("tree_hz", "number", "behaviour-tree ticks per second", default=10.0, lo=1.0, hi=50.0),
    Field("vehicle_hz", "number", "vehicle KCL (TPIK 1) rate, Hz", default=10.0, lo=5.0, hi=50.0),
    Field("arm_hz", "number", "arm KCL (TPIK 2) rate, Hz", default=100.0, lo=100.0, hi=1000.0),
)

SAFETY = fields(
    Field(
        "max_depth_m", "number", "deepest allowed vehicle depth, m", default=REQUIRED, lo=0.0, lo_open=True, hi=11000.0
    ),
    Field(
        "min_altitude_m",
        "number",
        "closest allowed distance to the bottom, m (needs an altitude sensor: a DVL)",
        default=REQUIRED,
        lo=0.0,
    ),
    Field(
        "max_duration_s",
        "number",
        "whole mission, s (operator pauses count too)",
        default=REQUIRED,
        lo=0.0,
        lo_open=True,
    ),
    Field("geofence", "geofence", "box in world NED, [low, high] each, m", default=REQUIRED),
    Field("watchdog_s", "watchdog", "max age (s) of each sensor stream's latest reading"),
)

GEOFENCE = fields(
    Field("north_m", "interval", "[low, high] world north, m", default=REQUIRED),
    Field("east_m", "interval", "[low, high] world east, m", default=REQUIRED),
    Field("down_m", "interval", "[low, high] world down (depth), m", default=REQUIRED),
)

#: Watchdog stream -> its field; ``null`` removes a default watchdog.
WATCHDOG = fields(
    *(
        Field(k, "number", doc, lo=0.0, lo_open=True, hi=60.0, nullable=True)
        for k, doc in (
            ("navigation", "navigation pose, s (default 0.5)"),
            ("joints", "arm joint readings, s (default 0.2)"),
            ("gripper", "gripper state, s (not watched unless listed)"),
            ("detector", "vision detector health, s (not watched unless listed)"),
            ("wrench", "wrist force/torque, s (not watched unless listed)"),
        )
    )
)
DEFAULT_WATCHDOG_S = {"navigation": 0.5, "joints": 0.2}

BLACKBOARD_ENTRY = fields(
    Field("type", "choice", "value type", default=REQUIRED, choices=("bool", "int", "float", "str", "pose", "point")),
    Field("value", "any", "initial value (none: unset)"),
)

# --------------------------------------------------------------------------- action parts

GOAL = fields(
    Field("north_m", "number", "world north, m"),
    Field("east_m", "number", "world east, m"),
    Field("down_m", "number", "world down (depth), m"),
    Field("altitude_m", "number", "height above the bottom, m (follows the bottom)", lo=0.0, lo_open=True),
    Field("yaw_deg", "number", "heading, degrees"),
)

TARGETS = fields(
    Field("vehicle_goal", "goal", "one goal; missing fields keep the pose at start; {} = stay here"),
    Field("waypoints", "goals", "goals visited in order (missing fields keep the previous goal's)"),
    Field("tolerance_m", "number", "distance at which a goal is reached, m", default=0.5, lo=0.0, lo_open=True),
    Field(
        "yaw_tolerance_deg",
        "number",
        "heading error at which a goal with yaw_deg is reached, degrees",
        default=10.0,
        lo=0.0,
        lo_open=True,
        hi=180.0,
    ),
    Field("loop", "bool", "restart the waypoints after the last one", default=False),
    Field("tool_goal_from", "string", "pose key: the tool frame's goal"),
    Field("camera_target_from", "string", "pose or point key: what the stereo camera keeps in view"),
)

TRACK = fields(
    Field("store_as", "string", "pose key the latest fresh detection is written to", default=REQUIRED),
    Field("min_confidence", "number", "least confidence, 0-1", default=0.5, lo=0.0, hi=1.0),
    Field("max_age_s", "number", "oldest usable detection (image time), s", default=1.0, lo=0.0, lo_open=True),
)

# --------------------------------------------------------------------------- teleop

#: The shared-control modes of a ``teleop`` node (behaviours.teleop).
TELEOP_MODES = ("tool_velocity", "vehicle_velocity", "vehicle_goal", "tool_goal", "point_at")
#: The operator input roles (hal.config_schema.OPERATOR_ROLES).
OPERATOR_INPUTS = ("gamepad", "foxglove", "keyboard")

HANDBACK = fields(
    Field(
        "button", "bool", "a `handback` press on any input hands back (gamepad start, a Publish button)", default=True
    ),
    Field("service", "bool", "the live view's /operator/handback service hands back", default=True),
    Field("until", "condition", "hands back when this condition holds (e.g. the pipe detected)"),
)

# --------------------------------------------------------------------------- nodes

CHILDREN = Field("children", "nodes", "child nodes, in order", default=REQUIRED)
CHILD = Field("child", "node", "the decorated node", default=REQUIRED)
MEMORY = Field(
    "memory", "bool", "true: resume at the running child; false: re-check earlier children every tick", default=True
)

NODE_DOCS = {
    "sequence": "runs children in order; fails at the first failure",
    "selector": "tries children in order; succeeds at the first success",
    "parallel": "ticks all children each tick",
    "timeout": "FAILURE if the child still runs after duration_s (backend clock)",
    "retry": "re-runs a failing child, fails after `attempts` failures",
    "repeat": "runs the child until it succeeded `times` times",
    "inverter": "swaps SUCCESS and FAILURE",
    "guard": "the child runs only while the condition holds",
    "one_shot": "runs the child to completion once, then keeps returning its result",
    "action": "run a KCL action",
    "condition": "SUCCESS if the condition holds at this tick",
    "gripper": "open, close or preshape the gripper",
    "wait": "wait (backend clock)",
    "set": "write a blackboard key",
    "log": "write an event to the run log",
    "subtree": "insert a tree from `subtrees:`",
    "teleop": "the operator drives under the safety tasks until they hand back",
}

NODE_FIELDS: dict[str, dict[str, Field]] = {
    "sequence": fields(NAME, CHILDREN, MEMORY),
    "selector": fields(NAME, CHILDREN, MEMORY),
    "parallel": fields(
        NAME,
        CHILDREN,
        Field(
            "policy",
            "choice",
            "success_on_all: all children succeed; success_on_one: the first success halts the others",
            default="success_on_all",
            choices=("success_on_all", "success_on_one"),
        ),
        Field("synchronise", "bool", "success_on_all: a child that succeeded is not ticked again", default=True),
    ),
    "timeout": fields(
        NAME, Field("duration_s", "number", "time limit, s", default=REQUIRED, lo=0.0, lo_open=True), CHILD
    ),
    "retry": fields(NAME, Field("attempts", "integer", "attempts before failing", default=REQUIRED, lo=1), CHILD),
    "repeat": fields(NAME, Field("times", "integer", "successes needed", default=REQUIRED, lo=1), CHILD),
    "inverter": fields(NAME, CHILD),
    "guard": fields(
        NAME, Field("condition", "condition", "checked before every tick of the child", default=REQUIRED), CHILD
    ),
    "one_shot": fields(
        NAME,
        Field(
            "on",
            "choice",
            "which results are kept",
            default="success_or_failure",
            choices=("success_or_failure", "success"),
        ),
        CHILD,
    ),
    "action": fields(
        NAME,
        Field(
            "run",
            "string",
            "action name from the actions file (survey, grasp, lift, transport, hold by default)",
            default=REQUIRED,
        ),
        Field("targets", "targets", "vehicle goal or waypoints, tool goal, camera target"),
        Field("until", "condition", "ends the action with SUCCESS when it holds"),
        Field("timeout_s", "number", "FAILURE after this time, s", lo=0.0, lo_open=True),
        Field("track_detection", "track", "keep writing the latest fresh detection to a pose key"),
    ),
    "condition": fields(NAME),  # plus exactly one condition kind (see CONDITION_FIELDS)
    "gripper": fields(
        NAME,
        Field("command", "choice", "what the gripper does", default=REQUIRED, choices=("open", "close", "preshape")),
        Field("shape", "string", "preshape name (preshape only), e.g. cylindrical"),
        Field(
            "current_limit_a",
            "number",
            "motor current at which closing stops, A (close only, required)",
            lo=0.0,
            lo_open=True,
        ),
        Field("timeout_s", "number", "FAILURE after this time, s", lo=0.0, lo_open=True),
        Field("wait", "bool", "true: RUNNING until done; false: SUCCESS right after sending", default=True),
    ),
    "wait": fields(NAME, Field("duration_s", "number", "how long, s", default=REQUIRED, lo=0.0)),
    "set": fields(
        NAME,
        Field("key", "string", "declared blackboard key", default=REQUIRED),
        Field("value", "scalar", "value to write (number, string or boolean)"),
        Field("add", "number", "number to add to the key"),
    ),
    "log": fields(
        NAME,
        Field("message", "string", "text of the event", default=REQUIRED),
        Field("level", "choice", "event level", default="info", choices=("info", "warning", "fault")),
    ),
    "subtree": fields(NAME, Field("use", "string", "name of a tree under `subtrees:`", default=REQUIRED)),
    "teleop": fields(
        NAME,
        Field("modes", "choices", "the modes the operator may use", default=TELEOP_MODES, choices=TELEOP_MODES),
        Field("start_mode", "choice", "the mode at the start (default: the first of `modes`)", choices=TELEOP_MODES),
        Field("inputs", "choices", "operator inputs listened to (default: every one present)", choices=OPERATOR_INPUTS),
        Field(
            "frame", "choice", "axes of the tool jog (tool_velocity)", default="vehicle", choices=("vehicle", "world")
        ),
        Field(
            "deadman_s",
            "number",
            "a velocity command acts this long after it was given; older ones are dropped, s",
            default=0.5,
            lo=0.05,
            hi=5.0,
        ),
        Field(
            "goal_max_age_s",
            "number",
            "goals older than this when they arrive are dropped, s",
            default=10.0,
            lo=0.0,
            lo_open=True,
            hi=600.0,
        ),
        Field(
            "timeout_s",
            "number",
            "FAILURE if the operator has not handed back after this time, s",
            lo=0.0,
            lo_open=True,
        ),
        Field("handback", "handback", "how the operator gives control back (default: button or service)"),
    ),
}

# --------------------------------------------------------------------------- conditions

COMPARISONS = ("equals", "not_equals", "below", "above", "at_most", "at_least", "is_set")
#: Conditions that may be written as a bare word (``until: converged``).
BARE_CONDITIONS = ("converged", "detected")

_RANGE = fields(Field("min", "number", "lower bound"), Field("max", "number", "upper bound"))

CONDITION_FIELDS: dict[str, dict[str, Field]] = {
    "detected": fields(
        Field("min_confidence", "number", "least confidence, 0-1", default=0.5, lo=0.0, hi=1.0),
        Field("max_age_s", "number", "oldest usable detection (image time), s", default=1.0, lo=0.0, lo_open=True),
        Field("store_as", "string", "pose key the grasp frame (world) is written to"),
    ),
    "grasp_detected": fields(
        Field("current_a", "number", "least motor current of a group, A", default=REQUIRED, lo=0.0, lo_open=True),
        Field("min_groups", "integer", "least number of motor groups at that current", default=1, lo=1),
    ),
    "converged": fields(
        Field("max_error", "number", "largest task error, m or rad (default 0.02)", lo=0.0, lo_open=True),
        Field("for_s", "number", "must hold this long, s (in an action's until only)", lo=0.0),
    ),
    "depth_m": _RANGE,
    "altitude_m": _RANGE,
    "force_n": _RANGE,
    "blackboard": fields(
        Field("key", "string", "declared blackboard key", default=REQUIRED),
        *(
            Field(
                op,
                "bool"
                if op == "is_set"
                else ("number" if op in ("below", "above", "at_most", "at_least") else "scalar"),
                f"comparison `{op}`",
            )
            for op in COMPARISONS
        ),
    ),
}

CONDITION_DOCS = {
    "detected": "the latest detection is fresh and confident enough",
    "grasp_detected": "the gripper holds and enough motor groups draw the current",
    "converged": "the controller's current action has converged",
    "depth_m": "measured depth within bounds, m",
    "altitude_m": "measured altitude within bounds, m (unknown: does not hold)",
    "force_n": "wrist force norm within bounds, N (no sensor: does not hold)",
    "blackboard": "a comparison on a blackboard key",
}

assert tuple(CONDITION_FIELDS) == PREDICATE_KINDS
