"""What the supervisor writes to the run log, topic by topic.

:class:`RunRecorder` wraps an optional :class:`mission.logs.writer.RunLogWriter`
(``None``: every method does nothing, so the loop never tests for a log). It
turns supervisor state into the messages of :mod:`mission.logs.channels` and
keeps the "write on change" memory (tree statuses, blackboard, device health,
last detection). Times are backend clock seconds.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from hal.interfaces import DeviceSet, Health
from kcl.telemetry import TelemetrySnapshot
from mission.logs import vision_channels as vision_log
from mission.logs.treeview import table_rows
from mission.runtime import telemetry as tm
from mission.runtime.context import Event


@dataclass
class KeptTelemetry:
    """A KCL telemetry snapshot and the safety margins of one step, not written yet."""

    t: float
    telemetry: TelemetrySnapshot
    margins: dict


class RunRecorder:
    def __init__(self, log: Any = None) -> None:
        self.log = log
        self._tree_signature: tuple | None = None
        self._blackboard: dict | None = None
        self._health: dict | None = None
        self._detection_t: float | None = None
        self._operator = False  # a teleop status was written and not yet followed by autonomy
        #: The tree last logged and its :func:`telemetry.tree_walk` (the node order of ``/tree``).
        self._walk_root: Any = None
        self._walk: list = []
        self._kcl: KeptTelemetry | None = None

    @property
    def active(self) -> bool:
        return self.log is not None

    @property
    def path(self) -> str | None:
        return str(self.log.path) if self.log is not None else None

    def event(self, ev: Event) -> None:
        if self.log is not None:
            self.log.write(
                "/events", ev.t, {"kind": ev.kind, "level": ev.level, "message": ev.message, "fields": ev.fields}
            )

    def state(self, t: float, previous: str, state: str, trigger: str, reason: str) -> None:
        if self.log is not None:
            self.log.write(
                "/supervisor/state", t, {"state": state, "previous": previous, "trigger": trigger, "reason": reason}
            )

    def health(self, t: float, health: dict[str, Health]) -> None:
        """Every device's health, when any state or detail changed."""
        if self.log is None:
            return
        states = {role: (h.state.value, h.detail) for role, h in health.items()}
        if states != self._health:
            self._health = states
            self.log.write(
                "/devices/health", t, {"devices": {r: {"state": s, "detail": d} for r, (s, d) in states.items()}}
            )

    def operator(self, t: float, status: dict[str, Any] | None) -> None:
        """Who has control: a running teleop leaf's status at each tree tick, then one
        ``autonomy`` message when it ends (``/operator/teleop``)."""
        if self.log is None:
            return
        if status is not None:
            self._operator = True
            self.log.write("/operator/teleop", t, status)
        elif self._operator:
            self._operator = False
            self.log.write("/operator/teleop", t, {"control": "autonomy", "limited_by": [], "dropped": 0})

    def tree(self, t: float, root: Any, tip: str | None, blackboard: Any) -> None:
        """Blackboard values and tree node statuses, each when it changed."""
        if self.log is None:
            return
        snapshot = getattr(blackboard, "snapshot", None)
        if snapshot is not None:
            values = snapshot()
            if values != self._blackboard:
                self._blackboard = values
                self.log.write("/blackboard", t, {"values": values})
        if self._walk_root is not root:  # a tree's shape is fixed once built: walked once
            self._walk_root, self._walk = root, tm.tree_walk(root)
        signature = tuple([(node.name, node.status) for node, _ in self._walk])
        if signature != self._tree_signature:
            self._tree_signature = signature
            nodes = tm.tree_nodes(root, self._walk)
            self.log.write(
                "/tree", t, {"nodes": nodes, "tip": tip, "root_status": root.status.value, "rows": table_rows(nodes)}
            )

    def kcl(self, t: float, telemetry: TelemetrySnapshot, margins: dict) -> None:
        """Keep the KCL telemetry (action, transition, per-task activation, error,
        reference) and the safety margins of time ``t`` (s) for :meth:`write_kcl`:
        the loop takes them at the tree tick's step and writes them at the next,
        so that the message is built off the loop's longest step. Their time is
        ``t`` either way. A snapshot still kept is written first."""
        if self.log is not None:
            self.write_kcl()
            self._kcl = KeptTelemetry(t, telemetry, margins)

    def write_kcl(self) -> None:
        """Write the telemetry and margins :meth:`kcl` kept, if any (the loop calls it
        at every step and once more when it ends)."""
        kept = self._kcl
        if kept is not None and self.log is not None:
            self._kcl = None
            self.log.write("/kcl", kept.t, kept.telemetry.message())
            self.log.write("/safety/margins", kept.t, {"margins": kept.margins})

    def devices(self, t: float, devices: DeviceSet, nav: Any, js: Any, vehicle_cmd: Any, arm_cmd: Any) -> None:
        """Device readings and the commands sent; a detection only when it is new."""
        log = self.log
        if log is None:
            return
        log.write("/vehicle/navigation", t, tm.navigation_message(nav))
        log.write("/vehicle/command", t, {"body_velocity": vehicle_cmd})
        log.write("/arm/state", t, tm.joint_message(js))
        log.write("/arm/command", t, {"velocity": arm_cmd})
        if devices.gripper is not None:
            log.write("/gripper/state", t, tm.gripper_message(devices.gripper.state()))
        if devices.wrench_sensor is not None:
            w = devices.wrench_sensor.wrench()
            if w is not None:
                log.write("/wrench", t, {"force": w.force, "torque": w.torque, "reading_t": w.t})
        if devices.detector is not None:
            det = devices.detector.latest()
            if det is not None and det.t != self._detection_t:
                self._detection_t = det.t
                log.write("/detector", t, tm.detection_message(det))
                vision_log.write_detection(log, t, det)
            vision_log.write_frames(log, t, devices.detector)

    def truth(self, t: float, msg: dict) -> None:
        if self.log is not None:
            self.log.write("/ground_truth", t, msg)

    def result(self, t: float, result: dict) -> None:
        if self.log is not None:
            self.log.write("/run/result", t, result)
