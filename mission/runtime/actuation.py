"""What the supervisor sends to the actuators, and how it stops them.

:class:`Actuation` holds the last commands (vehicle body velocity ``[u v w p q r]``
in m/s and rad/s, vehicle frame; arm joint velocities in rad/s) and owns the
ways motion starts and ends: engage (arm the thrusters, power the drives),
zero commands, the safe stop of every device, disengage. Stopping never raises:
a failure is reported as a ``safe_stop`` fault event and the others go on.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hal.interfaces import DeviceSet, EngageRefused
from mission.runtime.context import EventSink


class Actuation:
    def __init__(self, devices: DeviceSet, controller: Any, clock: Any, events: EventSink) -> None:
        self.devices = devices
        self.controller = controller
        self.clock = clock
        self.events = events
        self.n_joints = len(devices.arm.joint_names)
        #: Last commands sent (vehicle body velocity, joint velocities).
        self.vehicle_cmd = np.zeros(6)
        self.arm_cmd = np.zeros(self.n_joints)

    def send(self, vehicle_cmd: np.ndarray, arm_cmd: np.ndarray) -> None:
        """Send controller outputs (already checked finite) to the vehicle and the arm."""
        self.vehicle_cmd = vehicle_cmd
        self.arm_cmd = arm_cmd
        self.devices.vehicle.command_body_velocity(vehicle_cmd)
        self.devices.arm.command_joint_velocity(arm_cmd)

    def zero(self) -> None:
        """Command zero velocity to the vehicle and every joint."""
        self.vehicle_cmd = np.zeros(6)
        self.arm_cmd = np.zeros(self.n_joints)
        self.devices.vehicle.command_body_velocity(self.vehicle_cmd)
        self.devices.arm.command_joint_velocity(self.arm_cmd)

    def safe_stop_all(self) -> None:
        """Stop the controller, zero the commands and ``safe_stop()`` every device."""
        try:
            self.controller.stop(self.clock.now())
        except Exception as exc:  # noqa: BLE001
            self.events.emit("safe_stop", f"controller stop failed: {exc}", level="fault")
        self.zero()
        for role, dev in self.devices.by_role().items():
            try:
                dev.safe_stop()
            except Exception as exc:  # noqa: BLE001 - stopping must go on for the others
                self.events.emit("safe_stop", f"{role} safe_stop failed: {exc}", level="fault")

    def engage(self) -> list[str]:
        """Arm the thrusters and power the arm drives (motion still zero).

        Returns why not (empty when engaged): a device that refuses (e.g. the
        autopilot rejects the flight mode or fails its pre-arm checks) raises
        :class:`hal.interfaces.EngageRefused` with the reason."""

        self.zero()
        try:
            self.devices.vehicle.arm()
        except EngageRefused as exc:
            return [f"vehicle refused to arm: {exc}"]
        self.devices.arm.enable()
        self.events.emit("engage", "vehicle armed, arm drives enabled")
        return []

    def disengage(self) -> None:
        """Zero commands, disarm, unpower the arm; never raises."""
        for what, fn in (
            ("zero commands", self.zero),
            ("vehicle disarm", self.devices.vehicle.disarm),
            ("arm disable", self.devices.arm.disable),
        ):
            try:
                fn()
            except Exception as exc:  # noqa: BLE001
                self.events.emit("safe_stop", f"{what} failed: {exc}", level="fault")
