"""Device interfaces shared by the real drivers (:mod:`hal.drivers`) and the
simulator (:mod:`sim_backend`).

The supervisor, the behaviours and the KCL only ever see these types, so the same
behaviour tree drives real hardware or the simulator.

Conventions (everywhere in the project):

* World frame: NED, x north, y east, z down, metres. Depth = world z.
* Vehicle (body) frame: FRD, x forward, y starboard, z down, metres, origin at the
  vehicle reference point of the kinematic model.
* Attitude: roll, pitch, yaw (Z-Y-X Euler angles, Fossen's convention), radians.
* Body velocity ``v = [u, v, w, p, q, r]``: linear (m/s) then angular (rad/s),
  expressed in the vehicle frame. Index order of ``actuated_dofs`` is the same.
* Joint positions in rad, velocities in rad/s, motor currents in A.
* Time: seconds on the one shared :class:`Clock` of the backend. Every reading
  carries the time it was *measured* (not the time it was read), so consumers can
  detect stale data; a stale or missing reading is a fault, never silently reused.
"""

from __future__ import annotations

import enum
from abc import ABC, abstractmethod
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Protocol, cast, runtime_checkable

import numpy as np

#: Names of the six vehicle DOFs, in body-velocity order.
VEHICLE_DOFS: tuple[str, ...] = ("surge", "sway", "heave", "roll", "pitch", "yaw")

#: One flag per body DOF, in ``VEHICLE_DOFS`` order.
DofFlags = tuple[bool, bool, bool, bool, bool, bool]


def dof_flags(flags: Iterable[object]) -> DofFlags:
    """Six flags (``VEHICLE_DOFS`` order) as booleans; ValueError unless there are six."""
    surge, sway, heave, roll, pitch, yaw = (bool(f) for f in flags)
    return (surge, sway, heave, roll, pitch, yaw)


@runtime_checkable
class Clock(Protocol):
    """The shared time source of one backend."""

    def now(self) -> float:
        """Current time in seconds (simulated or monotonic wall time)."""
        ...


class HealthState(enum.Enum):
    """Coarse device health, ordered from good to bad."""

    OK = "ok"
    DEGRADED = "degraded"  # working, but something is off (e.g. low sensor rate)
    FAULT = "fault"  # not usable: drive fault, lost heartbeat, stale data
    MISSING = "missing"  # never connected / not present

    @property
    def usable(self) -> bool:
        return self in (HealthState.OK, HealthState.DEGRADED)


@dataclass(frozen=True)
class Health:
    """Health report of one device at time ``t`` (s); ``detail`` says why."""

    state: HealthState
    t: float
    detail: str = ""
    #: Free-form diagnostic values for ``maris hal check`` and the log
    #: (e.g. ``{"nmt": "OPERATIONAL", "cia402": "OPERATION ENABLED", "heartbeat_age_s": 0.1}``).
    info: dict = field(default_factory=dict)


def freshness(t_reading: float | None, now: float, timeout: float, what: str) -> Health:
    """Health of a reading measured at ``t_reading`` (s), judged at ``now`` (s).

    ``None`` (never received) gives MISSING; older than ``timeout`` (s) gives FAULT.
    """
    if t_reading is None:
        return Health(HealthState.MISSING, now, f"{what}: no reading received")
    age = now - t_reading
    if not np.isfinite(age) or age > timeout:
        return Health(HealthState.FAULT, now, f"{what}: stale reading ({age:.3f} s old, limit {timeout:.3f} s)")
    return Health(HealthState.OK, now, "", {"age_s": age})


class EngageRefused(RuntimeError):
    """A device refused to arm/enable (e.g. the autopilot rejected the flight mode
    or failed its pre-arm checks); the message says why, in the device's words."""


# --------------------------------------------------------------------------- readings


@dataclass(frozen=True)
class NavigationState:
    """Vehicle navigation solution.

    position: (3,) world NED, m. attitude: (3,) roll, pitch, yaw, rad.
    body_velocity: (6,) [u v w p q r] in the vehicle frame (m/s, rad/s), or
    ``None`` when no velocity measurement is available (e.g. no DVL); the angular
    part normally comes from the AHRS and the linear part from the DVL.
    velocity_t: measurement time (s) of ``body_velocity`` (None if absent).
    depth: m, positive down. altitude: m above the bottom, None if unknown.
    """

    t: float
    position: np.ndarray
    attitude: np.ndarray
    body_velocity: np.ndarray | None
    velocity_t: float | None
    depth: float
    altitude: float | None


@dataclass(frozen=True)
class JointState:
    """Arm joint readings at time ``t`` (s): position (rad), velocity (rad/s),
    motor current (A), one entry per joint; ``fault`` names the faulted joints' problem."""

    t: float
    position: np.ndarray
    velocity: np.ndarray
    current: np.ndarray
    fault: str | None = None


class GripperMotion(enum.Enum):
    IDLE = "idle"
    PRESHAPING = "preshaping"
    CLOSING = "closing"
    OPENING = "opening"
    HOLDING = "holding"  # closed and stalled on an object (current limit reached)
    STOPPED = "stopped"


@dataclass(frozen=True)
class GripperState:
    """Gripper readings at ``t`` (s) for its motor groups (MARIS: distal,
    proximal, palm): positions (rad), currents (A), what it is doing, fault text."""

    t: float
    positions: np.ndarray
    currents: np.ndarray
    motion: GripperMotion
    fault: str | None = None


@dataclass(frozen=True)
class Wrench:
    """Wrist force (N) and torque (N m) at ``t`` (s), in the sensor frame."""

    t: float
    force: np.ndarray
    torque: np.ndarray


@dataclass(frozen=True)
class Detection:
    """A target detection from the vision system.

    t: time (s) of the image it was computed from (not of its arrival).
    pose: (4, 4) homogeneous pose of the grasp frame in the vehicle frame (vTg), m.
    confidence: in [0, 1].
    """

    t: float
    pose: np.ndarray
    confidence: float
    #: What the vision system saw, JSON-able (camera-frame poses, visible end,
    #: edges, quality factors, why the confidence is low); None from simple models.
    details: dict | None = None


@dataclass(frozen=True)
class CameraFrame:
    """A downscaled camera image for logs and displays.

    t: image time (s, backend clock). camera: "left" / "right". jpeg: JPEG bytes.
    width, height: of the JPEG (px). frame_id: the optical frame's name.
    overlay: the detection drawn on this image (lines, circles, texts in this
    image's pixels, see :func:`vision.overlay.overlay_primitives`), or None.
    """

    t: float
    camera: str
    jpeg: bytes
    width: int
    height: int
    frame_id: str = "stereo_camera"
    overlay: dict | None = None


@dataclass(frozen=True)
class Stamped:
    """One operator command: ``values`` produced at ``t`` (s, backend clock: the time the
    operator gave it, the link's delay taken off when the input knows it), given in ``frame``
    (a frame name such as ``world``, ``map`` or ``vehicle_level`` for poses and points, the
    camera for image points; empty for velocities, whose axes are the mode's)."""

    t: float
    values: np.ndarray
    frame: str = ""


@dataclass(frozen=True)
class OperatorSample:
    """What an operator input says at ``t`` (s, backend clock: the last time its state was
    confirmed: a poll that found the device there, or its last message).

    deadman: the enabling switch is held (an input without one: True).
    velocity: (6,) ``[vx vy vz wx wy wz]`` (m/s, rad/s), in the axes of the current mode
    (tool jog: world or vehicle axes; vehicle jog: the vehicle frame, FRD).
    pose: (4, 4) goal pose in ``pose.frame``; point: (3,) goal point in ``point.frame``, m;
    image_point: (2,) ``[u, v]`` pixel of a click in the image of camera ``image_point.frame``.
    presses: cumulative count of each named button press since the device opened
    (``handback``, ``service:handback``, ``mode:<mode>``, ``mode:next``, ``frame:toggle``,
    ``stop``): a reader compares counts, so a press between two reads is never lost.
    """

    t: float
    deadman: bool
    velocity: Stamped | None = None
    pose: Stamped | None = None
    point: Stamped | None = None
    image_point: Stamped | None = None
    presses: dict[str, int] = field(default_factory=dict)

    def count(self, button: str) -> int:
        """Presses of ``button`` so far (0 if never pressed)."""
        return self.presses.get(button, 0)


@dataclass(frozen=True)
class SearchSeed:
    """Where the operator says the target is, for a detector's search: a world point
    (``point``, (3,) NED, m) or a pixel of a camera image (``image_point``, (2,) ``[u, v]``
    in ``camera``), within ``radius_px`` pixels; ``t``: when the operator gave it (s)."""

    t: float
    point: np.ndarray | None = None
    image_point: np.ndarray | None = None
    camera: str = "left"
    radius_px: float = 40.0


# --------------------------------------------------------------------------- devices


class Device(ABC):
    """Common life cycle of every device. Methods never block for long (a tick)."""

    name: str = "device"

    def connect(self) -> None:
        """Connect and bring the device to a ready (but not moving) state.

        (Named ``connect``, not ``open``, so that a gripper's ``open``/``close``
        can mean its fingers.)"""

    def disconnect(self) -> None:
        """Bring the device to a safe state and release its resources. Idempotent."""

    @abstractmethod
    def health(self) -> Health:
        """Current health; stale inputs must show up here as FAULT."""

    def safe_stop(self) -> None:
        """Stop all motion now (zero velocity / quick stop). Must not raise."""


class Vehicle(Device):
    """The vehicle: body velocity references in, navigation state out."""

    #: Which of the six body DOFs (``VEHICLE_DOFS`` order) the vehicle can actuate.
    actuated_dofs: DofFlags = (True,) * 6

    @abstractmethod
    def arm(self) -> None:
        """Enable the thrusters."""

    @abstractmethod
    def disarm(self) -> None:
        """Disable the thrusters."""

    @property
    @abstractmethod
    def armed(self) -> bool: ...

    @abstractmethod
    def command_body_velocity(self, v: np.ndarray) -> None:
        """Reference body velocity (6,) [m/s, rad/s] in the vehicle frame.

        Components of non-actuated DOFs are ignored."""

    @abstractmethod
    def navigation(self) -> NavigationState:
        """Latest navigation solution."""

    def safe_stop(self) -> None:
        self.command_body_velocity(np.zeros(6))


class Arm(Device):
    """The manipulator: joint velocity references in, joint state out."""

    joint_names: tuple[str, ...] = ()

    @abstractmethod
    def enable(self) -> None:
        """Power the drives so they follow velocity references."""

    @abstractmethod
    def disable(self) -> None:
        """Stop and unpower the drives (brakes / non-backdrivable gears hold)."""

    @abstractmethod
    def command_joint_velocity(self, qdot: np.ndarray) -> None:
        """Joint velocity references (rad/s), one per joint."""

    @abstractmethod
    def joint_state(self) -> JointState: ...

    def safe_stop(self) -> None:
        self.command_joint_velocity(np.zeros(len(self.joint_names)))


class Gripper(Device):
    """A multi-finger gripper with a few motor groups (MARIS: 3)."""

    #: Preshape names this gripper knows (e.g. "cylindrical", "parallel", "power").
    preshapes: tuple[str, ...] = ()

    @abstractmethod
    def preshape(self, shape: str) -> None:
        """Move to a named preshape (palm group), fingers open."""

    @abstractmethod
    def close(self, current_limit: float) -> None:
        """Close the fingers until each motor group reaches ``current_limit`` (A)
        or its end of travel."""

    @abstractmethod
    def open(self) -> None:
        """Open the fingers fully."""

    @abstractmethod
    def stop(self) -> None:
        """Stop all gripper motors where they are."""

    @abstractmethod
    def state(self) -> GripperState: ...

    def safe_stop(self) -> None:
        self.stop()


class ForceTorqueSensor(Device):
    @abstractmethod
    def wrench(self) -> Wrench | None:
        """Latest wrench, or None if none was ever received."""


class TargetDetector(Device):
    @abstractmethod
    def latest(self) -> Detection | None:
        """Latest detection (possibly old: check ``t``), or None if never detected."""

    def camera_frames(self) -> list[CameraFrame]:
        """Camera frames produced since the last call (downscaled, for the run
        log; at most a few per second). Detectors without images return none."""
        return []

    def seed_search(self, seed: SearchSeed) -> bool:
        """The operator's hint where the target is (a click on it in the camera image or
        the 3D view). True when this detector narrows its search with it; by default it
        does not (False), and the caller says so in the log."""
        return False


class OperatorInput(Device):
    """An operator's input device (a gamepad, the Foxglove live view, the terminal's
    keyboard): samples in, nothing out. Its health says whether the device is there
    (a gamepad unplugged: MISSING); whether its commands are fresh is for the reader
    to judge from their times (the dead-man)."""

    @abstractmethod
    def latest(self) -> OperatorSample | None:
        """The input's current state, or None before it produced anything."""

    def safe_stop(self) -> None:
        """Nothing moves: nothing to stop."""


#: The device roles of :class:`DeviceSet`'s own fields (operator inputs have roles of their own).
DEVICE_ROLES: tuple[str, ...] = ("vehicle", "arm", "gripper", "detector", "wrench_sensor")


@dataclass
class DeviceSet:
    """The devices of one vehicle, by role. Optional roles may be None.
    ``operators``: the operator inputs, by role (``gamepad``, ``foxglove``, ``keyboard``)."""

    vehicle: Vehicle
    arm: Arm
    gripper: Gripper | None = None
    detector: TargetDetector | None = None
    wrench_sensor: ForceTorqueSensor | None = None
    operators: dict[str, OperatorInput] = field(default_factory=dict)

    @classmethod
    def from_roles(cls, roles: dict[str, Device]) -> DeviceSet:
        """The set of ``roles`` (role -> device, as :meth:`by_role` gives them): the
        :data:`DEVICE_ROLES` to their fields, every other role an operator input."""
        others = {r: d for r, d in roles.items() if r not in DEVICE_ROLES}
        bad = [r for r, d in others.items() if not isinstance(d, OperatorInput)]
        if bad:
            raise ValueError(f"roles {', '.join(bad)} are neither device roles nor operator inputs")
        return cls(
            vehicle=cast(Vehicle, roles["vehicle"]),
            arm=cast(Arm, roles["arm"]),
            gripper=cast(Gripper | None, roles.get("gripper")),
            detector=cast(TargetDetector | None, roles.get("detector")),
            wrench_sensor=cast(ForceTorqueSensor | None, roles.get("wrench_sensor")),
            operators={r: d for r, d in others.items() if isinstance(d, OperatorInput)},
        )

    def by_role(self) -> dict[str, Device]:
        """Present devices keyed by role name ("vehicle", "arm", ..., then the operator inputs)."""
        roles: dict[str, Device | None] = {
            "vehicle": self.vehicle,
            "arm": self.arm,
            "gripper": self.gripper,
            "detector": self.detector,
            "wrench_sensor": self.wrench_sensor,
        }
        out = {k: v for k, v in roles.items() if v is not None}
        out.update(self.operators)
        return out


class Backend(ABC):
    """What the runtime drives: a clock, the devices, and the passage of time.

    The simulator advances physics in lockstep inside :meth:`advance`; a real
    backend sleeps until the clock reaches the requested time.
    """

    clock: Clock
    devices: DeviceSet
    #: True when time passes on its own (real devices or paced simulation).
    realtime: bool = False

    def open(self) -> None:
        """Connect every device."""
        for dev in self.devices.by_role().values():
            dev.connect()

    def close(self) -> None:
        """Safe-stop and disconnect every device; never raises."""
        for dev in self.devices.by_role().values():
            try:
                dev.safe_stop()
            except Exception:  # noqa: BLE001 - stopping must go on for the others
                pass
            try:
                dev.disconnect()
            except Exception:  # noqa: BLE001
                pass

    @abstractmethod
    def advance(self, dt: float) -> None:
        """Let ``dt`` seconds pass (simulate them, or wait for them)."""

    def prefetch_health(self) -> None:
        """The step after the next :meth:`advance` polls every device's ``health()``: a
        backend may compute it meanwhile (real drivers, between steps:
        :mod:`hal.drivers.health_prefetch`). By default nothing (a simulated health is cheap)."""

    def ground_truth(self) -> dict | None:
        """Simulator-only truth for logs and campaigns (e.g. tool-to-target
        distance, grasp result); None on real hardware."""
        return None

    def truth_brief(self) -> dict | None:
        """The part of :meth:`ground_truth` that a run without a log reads, at the
        truth rate: ``t``, ``tool_to_target_m``, ``grasp`` and ``events`` (a
        simulator computes only those); by default the whole truth."""
        return self.ground_truth()
