"""HAL device adapters over the simulator state (:class:`sim_backend.SimBackend`).

Each class implements one :mod:`hal.interfaces` device and only reads or writes
the backend's models; the physics lives in the model modules. Readings carry the
simulated time at which they were measured.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

import numpy as np

from hal.drivers.evemu import read_evemu
from hal.drivers.gamepad import XBOX360_RANGES, GamepadDecoder, gamepad_mapping
from hal.interfaces import (
    Arm,
    Detection,
    ForceTorqueSensor,
    Gripper,
    GripperState,
    Health,
    HealthState,
    JointState,
    NavigationState,
    OperatorInput,
    OperatorSample,
    TargetDetector,
    Vehicle,
    Wrench,
    dof_flags,
)

from .gripper_sim import PRESHAPE_PALM_RAD
from .sensor_kernel import A_ATT, A_POS, A_RATES, N_A
from .step_kernel import joint_readings

_new = object.__new__
#: a navigation reading's array (12,): attitude (3) rad, position (3) m, then the body velocity:
#: the DVL's (3) m/s and the AHRS rates (3) rad/s; the indices of each in the backend's ``nav_buffer``
_NAV_TAKE = np.array(
    [
        A_ATT,
        A_ATT + 1,
        A_ATT + 2,
        A_POS,
        A_POS + 1,
        A_POS + 2,
        N_A,
        N_A + 1,
        N_A + 2,
        A_RATES,
        A_RATES + 1,
        A_RATES + 2,
    ],
    dtype=np.intp,
)
_NAV_ATT, _NAV_POS, _NAV_VEL = slice(0, 3), slice(3, 6), slice(6, 12)


def _health(state: HealthState, t: float, detail: str = "", info: dict | None = None) -> Health:
    """``Health(state, t, detail, info)`` built as :func:`_reading` does (a new ``info`` dict)."""
    return _reading(Health, state=state, t=t, detail=detail, info={} if info is None else info)


R = TypeVar("R")


def _reading(cls: type[R], **fields: object) -> R:
    """A reading of the frozen dataclass ``cls`` with ``fields`` (all of them),
    without the generated ``__init__`` (which sets each field through
    ``object.__setattr__``, at several times the cost, every step): the same object.
    Only for plain field holders (no ``__post_init__``, no slots; a test checks)."""
    obj: R = _new(cls)
    obj.__dict__.update(fields)
    return obj


if TYPE_CHECKING:  # the backend imports this module: its type only
    from .backend import SimBackend

#: A DVL silent for longer than this (s) makes the vehicle DEGRADED.
DVL_STALE_S = 1.0


class SimVehicle(Vehicle):
    """Simulated vehicle: commands go to :class:`VehicleDynamics` (ignored while disarmed)."""

    name = "sim_vehicle"

    def __init__(self, sim: SimBackend):
        self._sim = sim
        self.actuated_dofs = dof_flags(sim.params["vehicle.actuated"])
        self._armed = False
        self._cache: NavigationState | None = None
        self._cache_t = -1.0

    def arm(self) -> None:
        self._armed = True

    def disarm(self) -> None:
        self._armed = False
        self._sim.vehicle.set_command(np.zeros(6))

    @property
    def armed(self) -> bool:
        return self._armed

    def command_body_velocity(self, v: np.ndarray) -> None:
        arr = np.asarray(v, dtype=float)
        if arr.shape != (6,):
            raise ValueError(f"body velocity must have shape (6,), got {arr.shape}")
        if self._armed:
            finite = self._sim.vehicle.set_command(arr)
        else:
            finite = bool(np.isfinite(arr).all())
        self._sim.note_command("vehicle", finite)

    def navigation(self) -> NavigationState:
        """The navigation solution now (one object per simulated instant: the sensors
        only change when the simulator advances; its arrays must not be modified)."""
        s = self._sim
        now = s.clock.t
        cache = self._cache
        if cache is not None and self._cache_t == now:
            return cache
        ahrs, dvl = s.ahrs, s.dvl
        with_vel = dvl.present and dvl.t is not None
        arrays = s.nav_buffer.take(_NAV_TAKE)  # one new array (copies), the fields are views
        self._cache_t = now
        altitude = dvl.altitude if dvl.present else None
        if s.ping.present:  # as the ArduSub driver: a fresh DVL altitude, else a fresh Ping one
            dvl_fresh = dvl.present and dvl.t is not None and now - dvl.t <= DVL_STALE_S
            if not dvl_fresh:
                altitude = s.ping.fresh_altitude(now)
        self._cache = _reading(
            NavigationState,
            t=ahrs.t if ahrs.t is not None else now,
            position=arrays[_NAV_POS],
            attitude=arrays[_NAV_ATT],
            body_velocity=arrays[_NAV_VEL] if with_vel else None,
            velocity_t=dvl.t if with_vel else None,
            depth=ahrs.depth,
            altitude=altitude,
        )
        return self._cache

    def health(self) -> Health:
        s = self._sim
        now = s.clock.now()
        if s.ahrs.nan_fault:
            return _health(HealthState.FAULT, now, "AHRS: invalid (NaN) attitude and rates")
        if not s.dvl.present:
            return _health(HealthState.OK, now, "", {"dvl": "absent"})
        age = None if s.dvl.t is None else now - s.dvl.t
        if age is None or age > DVL_STALE_S:
            return _health(HealthState.DEGRADED, now, "DVL: no bottom lock", {"dvl_age_s": age})
        return _health(HealthState.OK, now, "", {"dvl_age_s": age})


class SimArm(Arm):
    """Simulated arm: joint velocity references in, noisy encoders and currents out."""

    name = "sim_arm"

    def __init__(self, sim: SimBackend):
        self._sim = sim
        self.joint_names = tuple(sim.model.joint_names)
        self._cache: JointState | None = None
        self._encoder_noise = float(sim.params["arm.encoder_noise_rad"])
        self._current_noise = float(sim.params["arm.current_noise_a"])

    def enable(self) -> None:
        self._sim.arm.enabled = True

    def disable(self) -> None:
        self._sim.arm.enabled = False
        self._sim.arm.set_command(np.zeros(self._sim.arm.n))

    def command_joint_velocity(self, qdot: np.ndarray) -> None:
        qdot = np.asarray(qdot, dtype=float)
        if qdot.shape != (self._sim.arm.n,):
            raise ValueError(f"joint velocities must have shape ({self._sim.arm.n},), got {qdot.shape}")
        self._sim.note_command("arm", self._sim.arm.set_command(qdot))

    def joint_state(self) -> JointState:
        s = self._sim
        t = s.clock.t
        cache = self._cache
        if cache is not None and cache.t == t:
            return cache
        arm = s.arm
        n = arm.n
        buf, i = s.arm_noise.reserve(2 * n)
        out = np.empty(3 * n)  # a new array per reading: the JointState is kept by its readers
        joint_readings(
            arm.A, arm.enabled, arm.idle_current, arm.k_current, self._encoder_noise, self._current_noise, buf, i, out
        )
        fault = None
        if arm.faults:
            fault = "; ".join(f"{self.joint_names[j]}: {why}" for j, why in sorted(arm.faults.items()))
        self._cache = _reading(
            JointState, t=t, position=out[:n], velocity=out[n : 2 * n], current=out[2 * n :], fault=fault
        )
        return self._cache

    def health(self) -> Health:
        arm = self._sim.arm
        now = self._sim.clock.now()
        if arm.faults:
            return _health(HealthState.FAULT, now, self.joint_state().fault or "drive fault")
        return _health(HealthState.OK, now, "", {"enabled": arm.enabled})


class SimGripper(Gripper):
    """Simulated gripper: the three-motor MARIS hand (:mod:`sim_backend.gripper_sim`) or a
    Reach jaw with one motor (:mod:`sim_backend.jaw_sim`, ``gripper.model: jaw``)."""

    name = "sim_gripper"
    preshapes = tuple(PRESHAPE_PALM_RAD)

    def __init__(self, sim: SimBackend):
        self._sim = sim
        self._cache: GripperState | None = None
        self.preshapes = tuple(getattr(sim.gripper, "preshape_names", PRESHAPE_PALM_RAD))

    def preshape(self, shape: str) -> None:
        if shape not in self.preshapes:
            raise ValueError(f"unknown preshape {shape!r}; known: {', '.join(self.preshapes)}")
        self._sim.release_if_holding()
        self._sim.gripper.preshape(shape)

    def close(self, current_limit: float) -> None:
        if not current_limit > 0.0:
            raise ValueError(f"current limit must be positive, got {current_limit!r}")
        self._sim.gripper.close(current_limit)

    def open(self) -> None:
        """Open the fingers fully."""
        self._sim.release_if_holding()
        self._sim.gripper.open()

    def stop(self) -> None:
        self._sim.gripper.stop()

    def state(self) -> GripperState:
        s = self._sim
        t = s.clock.now()
        if self._cache is not None and self._cache.t == t:
            return self._cache
        g = s.gripper
        noise = s.params["gripper.current_noise_a"] * s.gripper_noise.take(len(g.current))
        self._cache = GripperState(
            t=t,
            positions=g.positions.copy(),
            currents=np.maximum(g.current + noise, 0.0),
            motion=g.motion,
            fault=g.fault,
        )
        return self._cache

    def health(self) -> Health:
        g = self._sim.gripper
        now = self._sim.clock.now()
        if g.fault:
            return _health(HealthState.FAULT, now, g.fault)
        return _health(HealthState.OK, now)


class SimDetector(TargetDetector):
    """Simulated stereo pipe detector (see :mod:`sim_backend.vision`)."""

    name = "sim_vision"

    def __init__(self, sim: SimBackend):
        self._sim = sim

    def latest(self) -> Detection | None:
        return self._sim.vision.latest()

    def camera_frames(self) -> list:
        """Rendered frames for the log (``vision.model: rendered``), else none."""
        frames = getattr(self._sim.vision, "camera_frames", None)
        return frames() if frames is not None else []

    def health(self) -> Health:
        now = self._sim.clock.now()
        d = self._sim.vision.latest()
        return _health(HealthState.OK, now, "", {"last_detection_age_s": None if d is None else now - d.t})


class SimWrenchSensor(ForceTorqueSensor):
    """Wrist force/torque sensor, modelled in the tool frame: it feels the wet
    weight of a held pipe (force and the torque of its lever arm) plus white
    noise; contact forces while closing and arm dynamics are not modelled."""

    name = "sim_wrench"

    def __init__(self, sim: SimBackend):
        self._sim = sim
        self._cache: Wrench | None = None

    def wrench(self) -> Wrench | None:
        s = self._sim
        t = s.clock.now()
        if self._cache is not None and self._cache.t == t:
            return self._cache
        force, torque = s.held_load_in_tool()
        n = s.ft_noise.take(6)
        self._cache = Wrench(
            t=t,
            force=force + s.params["ft.force_noise_n"] * n[:3],
            torque=torque + s.params["ft.torque_noise_nm"] * n[3:],
        )
        return self._cache

    def health(self) -> Health:
        return _health(HealthState.OK, self._sim.clock.now())


class SimGamepad(OperatorInput):
    """A gamepad replaying a recorded event stream (scenario ``operator.gamepad_recording``,
    :mod:`hal.drivers.evemu`) through the real driver's decoding
    (:class:`hal.drivers.gamepad.GamepadDecoder`, default mapping), in simulated time.

    The recording starts at ``operator.gamepad_start_s``, or (negative) at the first
    read: the first teleop node. At ``operator.gamepad_unplug_s`` the pad disappears:
    its health is MISSING and its last sample stops being confirmed, as when a real
    pad is pulled out. Without a recording the pad is there, untouched."""

    name = "sim_gamepad"

    def __init__(self, sim: SimBackend):
        self._clock = sim.clock
        p = sim.params
        path = str(p["operator.gamepad_recording"] or "")
        rec = read_evemu(Path(sim.scenario.source).parent / path) if path else None
        ranges = rec.axes if rec is not None and rec.axes else XBOX360_RANGES
        self._decoder = GamepadDecoder(gamepad_mapping(), ranges)
        self._events = rec.events if rec is not None else []
        self._next = 0
        self._start = float(p["operator.gamepad_start_s"])
        self._unplug = float(p["operator.gamepad_unplug_s"])
        self._t0: float | None = None if self._start < 0.0 else self._start
        self._cache: OperatorSample | None = None

    def latest(self) -> OperatorSample | None:
        now = self._clock.now()
        if self._t0 is None:
            self._t0 = now
        t = min(now, self._unplug)  # an unplugged pad's state was last confirmed when it went
        changed = False
        events, decoder = self._events, self._decoder
        while self._next < len(events) and self._t0 + events[self._next].t <= t:
            changed = decoder.feed(events[self._next]) or changed
            self._next += 1
        if self._cache is None or changed or self._cache.t != t:
            self._cache = decoder.sample(t)
        return self._cache

    def health(self) -> Health:
        now = self._clock.now()
        if now >= self._unplug:
            return _health(HealthState.MISSING, now, f"gamepad unplugged at {self._unplug:g} s")
        return _health(HealthState.OK, now, "", {"events_played": self._next, "events": len(self._events)})
