"""The checked, in-memory form of a mission file.

:func:`mission.loader.load_mission` builds these objects; nothing here parses
YAML. Everything is immutable. Units follow the key names (``_m`` metres,
``_s`` seconds, ``_hz`` hertz, ``_deg`` degrees in the file, radians in
memory where a field name says ``_rad``); positions are world NED.

A tree node is a :class:`Node`: its ``kind`` (``sequence``, ``action``, ...),
a readable ``name``, its checked ``params`` (plain Python values, keys as in
the file, defaults filled in) and its ``children``. Predicates (the
``until:`` of an action, a ``condition`` leaf, a ``guard``) are
:class:`Predicate` values stored inside ``params``.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from maris_common.yamlsrc import Mark

#: Node kinds, by family.
COMPOSITES = ("sequence", "selector", "parallel")
DECORATORS = ("timeout", "retry", "repeat", "inverter", "guard", "one_shot")
LEAVES = ("action", "condition", "gripper", "wait", "set", "log", "subtree", "teleop")
NODE_KINDS = COMPOSITES + DECORATORS + LEAVES
#: ``fallback`` is accepted in files as another name for ``selector``.
NODE_ALIASES = {"fallback": "selector"}

#: Predicate kinds usable in ``condition``, ``guard`` and ``until``.
PREDICATE_KINDS = ("detected", "grasp_detected", "converged", "depth_m", "altitude_m", "force_n", "blackboard")

#: Blackboard value types. ``pose``: (4, 4) homogeneous transform, world NED, m.
#: ``point``: (3,) world NED point, m.
BLACKBOARD_TYPES = ("bool", "int", "float", "str", "pose", "point")

#: Watchdog keys (sensor streams) and the device role each one watches.
WATCHDOG_ROLES = {
    "navigation": "vehicle",
    "joints": "arm",
    "gripper": "gripper",
    "detector": "detector",
    "wrench": "wrench_sensor",
}


class RoleSet(Protocol):
    """The devices a mission is checked against: a :class:`hal.config.HalConfig`, or
    the roles of a logged run (:class:`DeviceRoles`)."""

    @property
    def roles(self) -> frozenset[str]: ...


@dataclass(frozen=True)
class DeviceRoles:
    """Device roles alone (``vehicle``, ``arm``, ``gripper``...), without their drivers."""

    roles: frozenset[str]


@dataclass(frozen=True)
class Rates:
    """Loop rates of the supervisor, Hz."""

    tree_hz: float = 10.0
    vehicle_hz: float = 10.0
    arm_hz: float = 100.0


@dataclass(frozen=True)
class Geofence:
    """Axis-aligned box in the world NED frame; each bound is ``(low, high)`` in m."""

    north_m: tuple[float, float]
    east_m: tuple[float, float]
    down_m: tuple[float, float]

    def contains(self, position: Any) -> bool:
        """True if the world NED ``position`` (3,) m lies inside the box (bounds included)."""
        x, y, z = (float(v) for v in position[:3])
        return (
            self.north_m[0] <= x <= self.north_m[1]
            and self.east_m[0] <= y <= self.east_m[1]
            and self.down_m[0] <= z <= self.down_m[1]
        )


@dataclass(frozen=True)
class Safety:
    """The envelope the supervisor enforces; a breach runs the abort path.

    watchdog_s: sensor stream (see :data:`WATCHDOG_ROLES`) -> maximum age of
    its latest reading, s. Streams not listed are not watched.
    """

    max_depth_m: float
    min_altitude_m: float
    max_duration_s: float
    geofence: Geofence
    watchdog_s: Mapping[str, float]


@dataclass(frozen=True)
class BlackboardKey:
    """A declared blackboard entry: its type and initial value (None = unset)."""

    name: str
    type: str
    value: Any
    mark: Mark


@dataclass(frozen=True)
class Predicate:
    """A condition on the world or the blackboard, e.g. ``detected`` with its params."""

    kind: str
    params: Mapping[str, Any]
    mark: Mark
    path: tuple = ()

    def describe(self) -> str:
        """Short readable text, e.g. ``depth_m max=5`` or ``attempts below 3``."""
        return describe_predicate(self.kind, self.params)


def describe_predicate(kind: str, params: Mapping[str, Any]) -> str:
    """Readable text of a predicate (node names, messages)."""
    if kind == "blackboard" and params.get("op"):
        return f"{params.get('key')} {params['op'].replace('_', ' ')} {params.get('value')!r}"
    inner = " ".join(f"{k}={v}" for k, v in params.items() if v is not None)
    return f"{kind} {inner}".strip()


@dataclass(frozen=True)
class Node:
    """One node of the mission tree (see the module docstring)."""

    kind: str
    name: str
    params: Mapping[str, Any]
    children: tuple[Node, ...]
    mark: Mark
    path: tuple = ()

    @property
    def use(self) -> str:
        """The subtree a ``subtree`` node expands to ("" for other nodes)."""
        use = self.params.get("use")
        return use if isinstance(use, str) else ""

    def walk(self) -> Iterator[Node]:
        """This node and all its descendants, depth first (subtree refs not expanded)."""
        yield self
        for child in self.children:
            yield from child.walk()


@dataclass(frozen=True)
class Mission:
    """A loaded and checked mission.

    model: URDF path, or None for the default model of :mod:`kcl.model`.
    actions_file: actions YAML path, or None for ``kcl/data/actions.yaml``.
    tree: the main tree; subtrees: reusable trees by name (referenced by
    ``subtree`` leaves); abort: the tree the supervisor runs on abort or on a
    breach of the safety envelope.
    """

    name: str
    description: str
    file: str
    model: Path | None
    actions_file: Path | None
    rates: Rates
    safety: Safety
    blackboard: Mapping[str, BlackboardKey]
    tree: Node
    subtrees: Mapping[str, Node]
    abort: Node
    action_names: tuple[str, ...] = field(default=())
    #: The safety lint's warnings (:mod:`mission.lint`), ConfigIssues with severity "warning".
    warnings: tuple = field(default=())

    def initial_blackboard(self) -> dict[str, Any]:
        """Declared keys that have an initial value, key -> value."""
        return {k: v.value for k, v in self.blackboard.items() if v.value is not None}

    @property
    def uses_operator(self) -> bool:
        """Whether a ``teleop`` node (main tree, subtrees or abort tree) reads the operator inputs."""
        roots = (self.tree, self.abort, *self.subtrees.values())
        return any(node.kind == "teleop" for root in roots for node in root.walk())
