"""The jaw of a Reach arm (device 0x01) as the :class:`hal.interfaces.Gripper`
(driver ``reach_jaw``), on the arm's link (``link: arm`` in the HAL config).

The jaw is one linear actuator: position in mm (0 = closed, growing as it
opens), velocity in mm/s, current in mA. It streams POSITION, VELOCITY and
CURRENT as its heartbeat like the joints. Motions run in a service thread:

* ``close(current_limit)``: ``close_by: velocity`` drives it closed at
  ``close_speed`` and stops it (zero velocity) once its current reaches the
  limit; ``close_by: current`` demands the limit as its current (CURRENT mode,
  the grip force held by the device) and waits for it to stop moving. A jaw
  that stopped with the current at the limit (at least 80 % of it) short of
  its closed end holds an object: HOLDING (the grasp is confirmed from the
  current); one that reached ``closed_mm`` closed on nothing: STOPPED;
* ``open()`` and ``preshape(name)`` (``preshapes``: name -> opening in mm) move
  it to an opening at ``open_speed``: IDLE when there;
* ``stop()``: zero velocity.

Stale readings, hardware status flags or a lost link: health FAULT, motion
STOPPED, commands refused (RuntimeError) until :meth:`ReachJaw.reset_fault`.
The jaw joins the arm's exit paths (zero velocity and STANDBY, guardian).
States report the opening in m and the current in A, positive while squeezing
(the closing direction). The jaw's direction (0 mm closed) follows the Alpha's
URDF, whose finger angle grows with the rod position from closed.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from typing import Any

import numpy as np

from hal.config import site_of
from hal.drivers.reach_arm import link_spec
from hal.drivers.reach_device import ReachDevice
from hal.drivers.reach_link import ReachLink
from hal.drivers.reach_protocol import JAW_DEVICE, Mode, PacketId, encode_floats
from hal.interfaces import Gripper, GripperMotion, GripperState, Health, HealthState

POSITION_TOLERANCE_MM = 0.3
STALL_SPEED_MM_S = 0.2  # slower than this for STALL_TIME: the jaw stopped moving
STALL_TIME = 0.3  # s
HOLD_FRACTION = 0.8  # of the current limit: the current of a jaw stalled on an object


class ReachJaw(Gripper):
    """``params``: the validated ``reach_jaw`` config (link settings filled from the arm's)."""

    name = "gripper"

    def __init__(self, params: dict[str, Any], clock: Callable[[], float]) -> None:
        self._clock = clock
        self._where = site_of(params)
        self.link = ReachLink.shared(link_spec(params, site_of(params, "link")), clock)
        self.device = ReachDevice(self.link, params.get("device_id", JAW_DEVICE), "jaw")
        self.preshapes = tuple(params["preshapes"])
        self._preshape_mm = {k: float(v) for k, v in params["preshapes"].items()}
        self.close_by = params["close_by"]
        self.close_speed = float(params["close_speed"])
        self.open_speed = float(params["open_speed"])
        self.open_mm = float(params["open_mm"])
        self.closed_mm = float(params["closed_mm"])
        self.feedback_rate_hz = int(params["feedback_rate_hz"])
        self.stale_timeout = float(params["stale_timeout"])
        self.status_period = float(params["status_period"])
        self._lock = threading.Lock()
        self._motion = GripperMotion.IDLE
        self._goal_mm: float | None = None
        self._limit_ma = 0.0
        self._slow_since: float | None = None
        self._fault: str | None = None
        self._connected = False
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    # ------------------------------------------------------------------ life cycle
    def connect(self) -> None:
        d = self.device
        self.link.register(d.device_id, d.on_packet)
        try:
            self.link.acquire()
        except Exception:
            self.link.unregister(d.device_id)
            raise
        self._connected = True
        self.link.post(d.velocity_frame(0.0) + d.mode_frame(Mode.STANDBY) + d.heartbeat_setup(self.feedback_rate_hz))
        self.link.post(d.request_limits() + d.request_status())
        self._stop.clear()
        self._thread = threading.Thread(target=self._service, name="reach-jaw", daemon=True)
        self._thread.start()

    def disconnect(self) -> None:
        if not self._connected:
            return
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        d = self.device
        self.link.post(d.velocity_frame(0.0) + d.mode_frame(Mode.STANDBY))
        d.wait_mode(Mode.STANDBY, 1.0)
        self.link.unregister(d.device_id)
        self.link.release()
        self._connected = False

    # ------------------------------------------------------------------ problems
    def _problem(self, now: float) -> str | None:
        s = self.device.state
        where = f"jaw (device 0x{self.device.device_id:02X})"
        link = f"link {self.link.link_state}" + (f": {self.link.link_error}" if self.link.link_error else "")
        if s.position_t is None:
            return f"{where}: no reading received ({link})"
        times = (s.position_t, s.velocity_t, s.current_t)
        age = now - min(t if t is not None else -math.inf for t in times)
        if age > self.stale_timeout:
            return f"{where}: stale readings ({age:.3f} s old, limit {self.stale_timeout:.3f} s; {link})"
        if s.flags:
            return f"{where}: hardware status flags 0x{s.flags:08X}"
        return None

    # ------------------------------------------------------------------ commands
    def _start(self, motion: GripperMotion, goal_mm: float | None) -> None:
        why = self._fault or self._problem(self._clock())
        if why:  # a fault is never cleared by a motion command: see reset_fault()
            raise RuntimeError(f"gripper not usable: {why}")
        with self._lock:
            self._motion, self._goal_mm, self._slow_since = motion, goal_mm, None

    def reset_fault(self) -> None:
        """Clear a latched fault (motion IDLE, jaw in STANDBY)."""
        with self._lock:
            self._fault, self._motion = None, GripperMotion.IDLE
        d = self.device
        self.link.post(d.velocity_frame(0.0) + d.mode_frame(Mode.STANDBY))

    def reset_faults(self) -> list[str]:
        was = self._fault
        self.reset_fault()
        return [f"{self._where}: {was}"] if was else []

    def preshape(self, shape: str) -> None:
        if shape not in self._preshape_mm:
            raise ValueError(f"gripper: unknown preshape `{shape}`; known: {', '.join(self.preshapes)}")
        self._start(GripperMotion.PRESHAPING, self._preshape_mm[shape])

    def open(self) -> None:
        self._start(GripperMotion.OPENING, self.open_mm)

    def close(self, current_limit: float) -> None:
        if not current_limit > 0:
            raise ValueError(f"gripper: current limit must be > 0 A, got {current_limit}")
        self._start(GripperMotion.CLOSING, None)
        with self._lock:
            self._limit_ma = 1000.0 * float(current_limit)
        if self.close_by == "current":
            self.link.post(encode_floats(self.device.device_id, PacketId.CURRENT, [-self._limit_ma]))

    def stop(self) -> None:
        with self._lock:
            if self._motion not in (GripperMotion.HOLDING, GripperMotion.IDLE):
                self._motion = GripperMotion.STOPPED
        self.link.post(self.device.velocity_frame(0.0))

    def safe_stop(self) -> None:
        try:
            self.stop()
        except Exception:  # noqa: BLE001 - must not raise
            pass

    # ------------------------------------------------------------------ service thread
    def _service(self) -> None:
        next_status = 0.0
        while not self._stop.wait(0.02):
            now = self._clock()
            if now >= next_status:
                next_status = now + self.status_period
                self.link.post(self.device.request_status())
            why = self._problem(now)
            with self._lock:
                motion = self._motion
                if why and motion not in (GripperMotion.IDLE,) and self._fault is None:
                    self._fault = why
                if why and motion in (GripperMotion.CLOSING, GripperMotion.OPENING, GripperMotion.PRESHAPING):
                    self._motion = GripperMotion.STOPPED
                    motion = GripperMotion.STOPPED
                    self.link.post(self.device.velocity_frame(0.0) + self.device.mode_frame(Mode.STANDBY))
                    continue
            if motion in (GripperMotion.OPENING, GripperMotion.PRESHAPING):
                self._track(now)
            elif motion == GripperMotion.CLOSING:
                self._close_step(now)

    def _track(self, now: float) -> None:
        s = self.device.state
        goal = self._goal_mm if self._goal_mm is not None else self.open_mm
        err = goal - s.position
        if abs(err) < POSITION_TOLERANCE_MM:
            self.link.post(self.device.velocity_frame(0.0))
            with self._lock:
                self._motion = GripperMotion.IDLE
            return
        v = float(np.clip(3.0 * err, -self.open_speed, self.open_speed))
        self.link.post(self.device.velocity_frame(v))

    def _close_step(self, now: float) -> None:
        s = self.device.state
        limit = self._limit_ma
        if self.close_by == "velocity":
            if abs(s.current_ma) >= limit:
                self.link.post(self.device.velocity_frame(0.0))
                self._finish_close(s.position, abs(s.current_ma))
                return
            self.link.post(self.device.velocity_frame(-self.close_speed))
        if abs(s.velocity) < STALL_SPEED_MM_S:
            self._slow_since = self._slow_since if self._slow_since is not None else now
            if now - self._slow_since > STALL_TIME:
                if self.close_by == "velocity":
                    self.link.post(self.device.velocity_frame(0.0))
                self._finish_close(s.position, abs(s.current_ma))
        else:
            self._slow_since = None

    def _finish_close(self, position_mm: float, current_ma: float) -> None:
        """Stalled: on an object (HOLDING, squeezed on with the limit as a current demand,
        so the grip and the current that confirms it stay) or closed on nothing (STOPPED)."""
        on_object = (
            position_mm > self.closed_mm + POSITION_TOLERANCE_MM and current_ma >= HOLD_FRACTION * self._limit_ma
        )
        if on_object:
            self.link.post(encode_floats(self.device.device_id, PacketId.CURRENT, [-self._limit_ma]))
        with self._lock:
            self._motion = GripperMotion.HOLDING if on_object else GripperMotion.STOPPED

    # ------------------------------------------------------------------ readings
    def state(self) -> GripperState:
        now = self._clock()
        s = self.device.state
        with self._lock:
            motion, fault = self._motion, self._fault
        why = fault or self._problem(now)
        return GripperState(
            t=s.position_t if s.position_t is not None else float("nan"),
            positions=np.array([s.position / 1000.0]),
            currents=np.array([-s.current_ma / 1000.0]),  # positive while squeezing (closing direction)
            motion=motion,
            fault=why,
        )

    def health(self) -> Health:
        now = self._clock()
        s = self.device.snapshot()
        why = self._fault or self._problem(now)
        info: dict[str, Any] = {
            "parts": [
                {
                    "name": "jaw",
                    "state": (
                        HealthState.MISSING if s.position_t is None else HealthState.FAULT if why else HealthState.OK
                    ).value,
                    "detail": why or "",
                    "device_id": f"0x{self.device.device_id:02X}",
                    "mode": self.device.describe_mode(),
                    "opening_mm": None if s.position_t is None else round(s.position, 2),
                    "current_ma": None if s.current_t is None else round(s.current_ma, 1),
                    "close_by": self.close_by,
                }
            ],
            **self.link.info(now),
        }
        if s.position_t is None:
            return Health(HealthState.MISSING, now, why or "jaw: not heard from", info)
        return Health(HealthState.FAULT if why else HealthState.OK, now, why or "", info)
