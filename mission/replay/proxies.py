"""Recording stand-ins for the devices of a :class:`hal.interfaces.DeviceSet`.

Each proxy behaves exactly like the wrapped device and notes, through the
shared :class:`mission.replay.steplog.Recorder`, what each read returned (or
raised) and every command sent; what all proxies do alike (health, safe stop,
the life cycle) is their base, :class:`RecordedDevice`. A driver's own public methods (beyond its
:mod:`hal.interfaces` role, e.g. ``reset_faults``) are recorded with their
arguments and results; its other attributes pass through unrecorded.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hal.interfaces import (
    Arm,
    CameraFrame,
    Detection,
    Device,
    ForceTorqueSensor,
    Gripper,
    GripperState,
    Health,
    JointState,
    NavigationState,
    OperatorInput,
    OperatorSample,
    SearchSeed,
    TargetDetector,
    Vehicle,
    Wrench,
    dof_flags,
)
from mission.replay import codec
from mission.replay.steplog import Recorder


class RecordedDevice(Device):
    """What every recording proxy does alike for its device (``inner``, in ``role``):
    health and safe stop recorded, the driver's own methods recorded, the life cycle
    forwarded. The role proxies below derive from it and from their role's interface."""

    def __init__(self, inner: Device, role: str, rec: Recorder) -> None:
        self._inner: Any = inner
        self._role = role
        self._rec = rec
        self.name: str = getattr(inner, "name", role)
        self._health = rec.stream(f"{role}.health")
        self._safe_stop_call = f"{role}.safe_stop"
        self._extras = frozenset(extra_methods(inner))

    def __getattr__(self, name: str) -> Any:
        """The driver's own methods, recorded (``reset_faults``...); its other public
        attributes as they are, unrecorded (supervisor code must not depend on them: a
        replay has none)."""
        if name.startswith("_"):
            raise AttributeError(name)
        attr = getattr(self._inner, name)
        if name not in self._extras:
            return attr
        stream = self._rec.stream(f"{self._role}.{name}")
        rec = self._rec
        return lambda *args, **kwargs: rec.call(stream, attr, args, kwargs)

    def connect(self) -> None:
        self._inner.connect()

    def disconnect(self) -> None:
        self._inner.disconnect()

    def health(self) -> Health:
        return self._rec.read(self._health, self._inner.health, codec.enc_health)

    def safe_stop(self) -> None:
        self._rec.command(self._safe_stop_call, self._inner.safe_stop)


class RecordingVehicle(RecordedDevice, Vehicle):
    def __init__(self, inner: Vehicle, rec: Recorder) -> None:
        super().__init__(inner, "vehicle", rec)
        self.actuated_dofs = dof_flags(inner.actuated_dofs)
        self._nav = rec.stream("vehicle.navigation")
        self._armed = rec.stream("vehicle.armed")

    def arm(self) -> None:
        self._rec.command("vehicle.arm", self._inner.arm)

    def disarm(self) -> None:
        self._rec.command("vehicle.disarm", self._inner.disarm)

    @property
    def armed(self) -> bool:
        return self._rec.read(self._armed, lambda: self._inner.armed, codec.enc_bool)

    def command_body_velocity(self, v: np.ndarray) -> None:
        self._rec.command("vehicle.command_body_velocity", self._inner.command_body_velocity, v, values=v)

    def navigation(self) -> NavigationState:
        return self._rec.read(self._nav, self._inner.navigation, codec.enc_navigation)


class RecordingArm(RecordedDevice, Arm):
    def __init__(self, inner: Arm, rec: Recorder) -> None:
        super().__init__(inner, "arm", rec)
        self.joint_names = tuple(inner.joint_names)
        self._js = rec.stream("arm.joint_state")

    def enable(self) -> None:
        self._rec.command("arm.enable", self._inner.enable)

    def disable(self) -> None:
        self._rec.command("arm.disable", self._inner.disable)

    def command_joint_velocity(self, qdot: np.ndarray) -> None:
        self._rec.command("arm.command_joint_velocity", self._inner.command_joint_velocity, qdot, values=qdot)

    def joint_state(self) -> JointState:
        return self._rec.read(self._js, self._inner.joint_state, codec.enc_joints)


class RecordingGripper(RecordedDevice, Gripper):
    def __init__(self, inner: Gripper, rec: Recorder) -> None:
        super().__init__(inner, "gripper", rec)
        self.preshapes = tuple(inner.preshapes)
        self._state = rec.stream("gripper.state")

    def preshape(self, shape: str) -> None:
        self._rec.command("gripper.preshape", self._inner.preshape, shape, text=str(shape))

    def close(self, current_limit: float) -> None:
        self._rec.command("gripper.close", self._inner.close, current_limit, values=[current_limit])

    def open(self) -> None:
        self._rec.command("gripper.open", self._inner.open)

    def stop(self) -> None:
        self._rec.command("gripper.stop", self._inner.stop)

    def state(self) -> GripperState:
        return self._rec.read(self._state, self._inner.state, codec.enc_gripper)


class RecordingWrenchSensor(RecordedDevice, ForceTorqueSensor):
    def __init__(self, inner: ForceTorqueSensor, rec: Recorder) -> None:
        super().__init__(inner, "wrench_sensor", rec)
        self._w = rec.stream("wrench_sensor.wrench")

    def wrench(self) -> Wrench | None:
        return self._rec.read(self._w, self._inner.wrench, codec.enc_wrench)


class RecordingDetector(RecordedDevice, TargetDetector):
    def __init__(self, inner: TargetDetector, rec: Recorder) -> None:
        super().__init__(inner, "detector", rec)
        self._latest = rec.stream("detector.latest")
        self._seed = rec.stream("detector.seed_search")

    def latest(self) -> Detection | None:
        return self._rec.read(self._latest, self._inner.latest, codec.enc_detection)

    def camera_frames(self) -> list[CameraFrame]:
        """The detector's images, for the log's vision channels only (no decision reads
        them): passed on, not recorded (a replay has none)."""
        return self._inner.camera_frames()

    def seed_search(self, seed: SearchSeed) -> bool:
        """The operator's search seed: its arguments and the detector's answer recorded."""
        inner = self._inner
        return bool(self._rec.call(self._seed, lambda **_: inner.seed_search(seed), (), {"seed": codec.enc_seed(seed)}))


class RecordingOperatorInput(RecordedDevice, OperatorInput):
    """An operator input (any operator role): each sample the supervisor reads, recorded."""

    def __init__(self, inner: OperatorInput, role: str, rec: Recorder) -> None:
        super().__init__(inner, role, rec)
        self._latest = rec.stream(f"{role}.latest")

    def latest(self) -> OperatorSample | None:
        return self._rec.read(self._latest, self._inner.latest, codec.enc_operator)


PROXIES = {
    "vehicle": RecordingVehicle,
    "arm": RecordingArm,
    "gripper": RecordingGripper,
    "wrench_sensor": RecordingWrenchSensor,
    "detector": RecordingDetector,
}


def recording_proxy(role: str, device: Device, rec: Recorder) -> Device:
    """The recording stand-in for ``device`` in ``role`` (an operator input in any operator role)."""
    if isinstance(device, OperatorInput) and role not in PROXIES:
        return RecordingOperatorInput(device, role, rec)
    return PROXIES[role](device, rec)


_INTERFACES = {
    "vehicle": Vehicle,
    "arm": Arm,
    "gripper": Gripper,
    "wrench_sensor": ForceTorqueSensor,
    "detector": TargetDetector,
}


def extra_methods(device: Any) -> list[str]:
    """Public methods of ``device``'s class beyond its :mod:`hal.interfaces` role."""
    base = next((cls for cls in (*_INTERFACES.values(), OperatorInput) if isinstance(device, cls)), object)
    known = set(dir(base))
    return sorted(
        n
        for n in dir(type(device))
        if not n.startswith("_") and n not in known and callable(getattr(type(device), n, None))
    )
