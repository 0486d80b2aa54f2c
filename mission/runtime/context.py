"""The concrete :class:`behaviours.context.MissionContext` the supervisor hands
to the behaviour-tree leaves.

Leaves see the backend clock, the devices, the KCL controller, the mission
blackboard and an event sink; ``stop_motion()`` zeroes the controller output and
commands zero velocities at once (the halt contract of interrupted leaves).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from behaviours.context import OperatorBoard
from hal.interfaces import Clock, DeviceSet

#: Event levels; ``fault`` events also show up in the summary.
LEVELS = ("info", "warning", "fault")


@dataclass(frozen=True)
class Event:
    t: float
    kind: str
    message: str
    level: str = "info"
    fields: dict = field(default_factory=dict)


class EventSink:
    """Collects events and forwards each to listeners (log writer, progress display)."""

    def __init__(self, clock: Clock) -> None:
        self._clock = clock
        self.events: list[Event] = []
        self.listeners: list[Callable[[Event], None]] = []

    def emit(self, kind: str, message: str, **fields: Any) -> Event:
        """Record an event at the current backend time. ``level=`` (info, warning,
        fault) may be passed among the fields; the rest is stored with the event."""
        level = str(fields.pop("level", "info"))
        if level not in LEVELS:
            level = "info"
        ev = Event(self._clock.now(), str(kind), str(message), level, fields)
        self.events.append(ev)
        for listener in self.listeners:
            listener(ev)
        return ev


class RuntimeContext:
    """What the leaves may touch. ``controller`` is a :class:`kcl.controller.UvmsController`."""

    def __init__(
        self,
        clock: Clock,
        devices: DeviceSet,
        controller: Any,
        blackboard: Any,
        events: EventSink,
        *,
        mission: Any = None,
        model: Any = None,
    ) -> None:
        self.clock = clock
        self.devices = devices
        self.controller = controller
        self.blackboard = blackboard
        self.events = events
        self.mission = mission
        self.model = model
        #: Who has control: the running teleop leaf's status (None: autonomy).
        self.operator = OperatorBoard()

    def now(self) -> float:
        """Backend clock, s."""
        return self.clock.now()

    def stop_motion(self) -> None:
        """Zero the KCL output and command zero vehicle and joint velocities now."""
        t = self.clock.now()
        if self.controller is not None:
            self.controller.stop(t)
        self.devices.vehicle.command_body_velocity(np.zeros(6))
        self.devices.arm.command_joint_velocity(np.zeros(len(self.devices.arm.joint_names)))

    def emit(self, kind: str, message: str, **fields: Any):
        return self.events.emit(kind, message, **fields)
