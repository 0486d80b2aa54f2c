"""MAVLink link to an ArduSub autopilot (BlueROV2 and similar) with pymavlink.

:class:`ArdusubLink` owns the connection (any pymavlink URL: ``udpin:``,
``udpout:``, ``tcp:``, serial device) and two background threads:

* receive: decodes HEARTBEAT (mode, armed flag; only from a MAV_TYPE_SUBMARINE
  autopilot), ATTITUDE, LOCAL_POSITION_NED, VFR_HUD, DISTANCE_SENSOR (downward),
  RANGEFINDER and COMMAND_ACK, each stamped with the backend clock on arrival;
* transmit: our GCS heartbeat at 1 Hz and the latest velocity setpoint at
  ``SETPOINT_RATE`` Hz. A setpoint older than ``COMMAND_TIMEOUT`` is replaced by
  zero, so the vehicle stops if our control loop dies.

Velocity commands (``command: setpoint``, the default) use
SET_POSITION_TARGET_LOCAL_NED in GUIDED mode with MAV_FRAME_BODY_OFFSET_NED,
velocities + yaw rate only (type mask 0x05C7); GUIDED needs a position
estimate in ArduSub (DVL forwarded to the autopilot). Without one,
``command: manual_control`` sends MANUAL_CONTROL sticks scaled by
``max_speed`` / ``max_yaw_rate`` in a manual mode (open loop: sticks are thrust
demands, so the KCL's velocity reference is only approximately followed).
Caveat (ArduPilot semantics): in the BODY frames ArduSub rotates the
horizontal velocity by heading only, and w is along NED down; with the small
roll/pitch of a stabilised ROV this equals the body frame. Roll and pitch rates
are not commanded (BlueROV2 keeps them level).

Nothing here blocks a tick: commands only store values or queue one message.
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np
from pymavlink import mavutil

from hal.drivers.realtime import rate_of

log = logging.getLogger(__name__)

MAV = mavutil.mavlink
SETPOINT_RATE = 10.0  # Hz
COMMAND_TIMEOUT = 0.5  # s
VELOCITY_TYPE_MASK = 0x05C7  # ignore position, acceleration, yaw; use velocity + yaw rate
SUB_MODES: dict[int, str] = dict(mavutil.mode_mapping_sub)
SUB_MODE_IDS: dict[str, int] = {v: k for k, v in SUB_MODES.items()}


@dataclass(frozen=True)
class Telemetry:
    """Latest autopilot telemetry; every ``*_t`` is the backend time (s) of arrival, None if never."""

    heartbeat_t: float | None
    mode: str
    armed: bool
    attitude: np.ndarray  # roll, pitch, yaw (rad)
    rates: np.ndarray  # p, q, r (rad/s)
    attitude_t: float | None
    position: np.ndarray  # NED (m), EKF origin
    velocity_ned: np.ndarray  # m/s
    position_t: float | None
    depth: float | None  # m, positive down
    depth_t: float | None
    altitude: float | None  # m above the bottom
    altitude_t: float | None
    rates_hz: dict


def manual_control_axes(sp: np.ndarray, max_speed: float, max_yaw_rate: float) -> tuple[int, int, int, int]:
    """MANUAL_CONTROL stick values for a setpoint [u, v, w, r]: x, y, r in -1000..1000
    (full stick = max_speed / max_yaw_rate), z in 0..1000 with 500 neutral and up
    positive (so w, positive down, lowers it). Open loop: sticks are thrust demands."""
    def stick(value: float, full: float) -> int:
        return int(round(float(np.clip(value / full, -1.0, 1.0)) * 1000))

    return stick(sp[0], max_speed), stick(sp[1], max_speed), 500 - stick(sp[2], max_speed) // 2, stick(sp[3], max_yaw_rate)


class RateMeter:
    """Messages per second over a sliding window."""

    def __init__(self, window: float = 5.0) -> None:
        self.window = window
        self._times: dict[str, list[float]] = {}

    def tick(self, name: str, t: float) -> None:
        ts = self._times.setdefault(name, [])
        ts.append(t)
        while ts and ts[0] < t - self.window:
            ts.pop(0)

    def rates(self, now: float) -> dict[str, float]:
        return {k: rate_of([t for t in v if t >= now - self.window]) for k, v in self._times.items()}



class ArdusubLink:
    """Connection to one ArduSub autopilot. ``clock`` gives the backend time (s)."""

    def __init__(self, url: str, clock: Callable[[], float], *, baudrate: int = 115200, source_system: int = 255,
                 target_system: int = 1, arm_mode: str = "GUIDED", command: str = "setpoint", max_speed: float = 1.0,
                 max_yaw_rate: float = 0.5) -> None:
        self.url = url
        self._clock = clock
        self._baud = baudrate
        self._source_system = source_system
        self.target_system = target_system
        self.target_component = 1
        if arm_mode not in SUB_MODE_IDS:
            raise ValueError(f"unknown ArduSub mode {arm_mode!r}; known: {', '.join(SUB_MODE_IDS)}")
        if command not in ("setpoint", "manual_control"):
            raise ValueError(f"unknown command kind {command!r}")
        self.arm_mode = arm_mode
        self.command = command
        self.max_speed = max_speed
        self.max_yaw_rate = max_yaw_rate
        self._conn = None
        self._lock = threading.Lock()
        self._send_lock = threading.Lock()
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._setpoint = np.zeros(4)  # u, v, w, r
        self._setpoint_t = -1e9
        self._streaming = False
        self.acks: dict[int, int] = {}
        self._meter = RateMeter()
        self._hb_t: float | None = None
        self._mode = "UNKNOWN"
        self._armed = False
        self._att = np.zeros(3)
        self._rates = np.zeros(3)
        self._att_t: float | None = None
        self._pos = np.zeros(3)
        self._vel = np.zeros(3)
        self._pos_t: float | None = None
        self._depth: float | None = None
        self._depth_t: float | None = None
        self._alt: float | None = None
        self._alt_t: float | None = None
        self.rx_errors = 0

    # ------------------------------------------------------------------ life cycle

    def connect(self) -> None:
        """Open the connection and start the threads (does not wait for the vehicle)."""
        if self._conn is not None:
            return
        self._conn = mavutil.mavlink_connection(self.url, baud=self._baud, source_system=self._source_system,
                                                source_component=MAV.MAV_COMP_ID_MISSIONPLANNER, dialect="ardupilotmega")
        self._stop.clear()
        for target, name in ((self._rx_loop, "mavlink-rx"), (self._tx_loop, "mavlink-tx")):
            th = threading.Thread(target=target, name=name, daemon=True)
            th.start()
            self._threads.append(th)

    def close(self) -> None:
        """Zero setpoint, stop the threads, close the connection. Idempotent."""
        if self._conn is None:
            return
        self.set_velocity(np.zeros(6))
        self._send_setpoint()
        self._stop.set()
        for th in self._threads:
            th.join(timeout=1.0)
        self._threads.clear()
        try:
            self._conn.close()
        except Exception:  # noqa: BLE001
            pass
        self._conn = None

    # ------------------------------------------------------------------ commands

    def set_velocity(self, v: np.ndarray) -> None:
        """Body velocity reference (6,) [u v w p q r]; p, q ignored; clipped; non-finite -> zero."""
        v = np.asarray(v, dtype=float).reshape(6)
        if not np.all(np.isfinite(v)):
            v = np.zeros(6)
        lin = np.clip(v[:3], -self.max_speed, self.max_speed)
        r = float(np.clip(v[5], -self.max_yaw_rate, self.max_yaw_rate))
        with self._lock:
            self._setpoint = np.array([lin[0], lin[1], lin[2], r])
            self._setpoint_t = self._clock()
            self._streaming = True

    def arm(self, armed: bool = True) -> None:
        """Switch to the guided mode (when arming) and send the arm/disarm command."""
        if armed:
            self.set_mode(self.arm_mode)
        self._send(lambda m: m.command_long_send(self.target_system, self.target_component,
                                                 MAV.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1 if armed else 0, 0, 0, 0, 0, 0, 0))

    def set_mode(self, mode: str) -> None:
        mode_id = SUB_MODE_IDS[mode]
        self._send(lambda m: m.set_mode_send(self.target_system, MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode_id))

    def _send(self, fn: Callable) -> None:
        conn = self._conn
        if conn is None:
            return
        try:
            with self._send_lock:
                fn(conn.mav)
        except OSError as exc:  # link down: shows up as a lost heartbeat
            log.debug("MAVLink send failed: %s", exc)

    def _send_setpoint(self) -> None:
        with self._lock:
            sp = self._setpoint.copy() if self._clock() - self._setpoint_t < COMMAND_TIMEOUT else np.zeros(4)
        if self.command == "manual_control":
            x, y, z, r = manual_control_axes(sp, self.max_speed, self.max_yaw_rate)
            self._send(lambda m: m.manual_control_send(self.target_system, x, y, z, r, 0))
            return
        boot_ms = int(self._clock() * 1000) & 0xFFFFFFFF
        self._send(lambda m: m.set_position_target_local_ned_send(
            boot_ms, self.target_system, self.target_component, MAV.MAV_FRAME_BODY_OFFSET_NED, VELOCITY_TYPE_MASK,
            0, 0, 0, sp[0], sp[1], sp[2], 0, 0, 0, 0, sp[3]))

    # ------------------------------------------------------------------ threads

    def _tx_loop(self) -> None:
        next_hb = 0.0
        period = 1.0 / SETPOINT_RATE
        while not self._stop.wait(period):
            now = time.monotonic()
            if now >= next_hb:
                next_hb = now + 1.0
                self._send(lambda m: m.heartbeat_send(MAV.MAV_TYPE_GCS, MAV.MAV_AUTOPILOT_INVALID, 0, 0, 0))
            if self._streaming:
                self._send_setpoint()

    def _rx_loop(self) -> None:
        while not self._stop.is_set():
            try:
                msg = self._conn.recv_match(blocking=True, timeout=0.1)
            except Exception as exc:  # noqa: BLE001 - a broken link is reported as lost heartbeat
                self.rx_errors += 1
                log.debug("MAVLink receive failed: %s", exc)
                time.sleep(0.1)
                continue
            if msg is not None:
                self._handle(msg)

    def _handle(self, msg) -> None:  # noqa: ANN001 - pymavlink message
        kind = msg.get_type()
        if kind == "BAD_DATA" or msg.get_srcSystem() != self.target_system:
            return
        now = self._clock()
        with self._lock:
            self._meter.tick(kind, now)
            if kind == "HEARTBEAT":
                if msg.type != MAV.MAV_TYPE_SUBMARINE or msg.autopilot == MAV.MAV_AUTOPILOT_INVALID:
                    return
                self._hb_t = now
                self._armed = bool(msg.base_mode & MAV.MAV_MODE_FLAG_SAFETY_ARMED)
                self._mode = SUB_MODES.get(msg.custom_mode, f"mode {msg.custom_mode}")
            elif kind == "ATTITUDE":
                att = np.array([msg.roll, msg.pitch, msg.yaw])
                rates = np.array([msg.rollspeed, msg.pitchspeed, msg.yawspeed])
                if np.all(np.isfinite(att)) and np.all(np.isfinite(rates)):
                    self._att, self._rates, self._att_t = att, rates, now
            elif kind == "LOCAL_POSITION_NED":
                pos = np.array([msg.x, msg.y, msg.z])
                vel = np.array([msg.vx, msg.vy, msg.vz])
                if np.all(np.isfinite(pos)) and np.all(np.isfinite(vel)):
                    self._pos, self._vel, self._pos_t = pos, vel, now
                    self._depth, self._depth_t = float(msg.z), now
            elif kind == "VFR_HUD" and self._pos_t is None and np.isfinite(msg.alt):
                self._depth, self._depth_t = -float(msg.alt), now
            elif kind == "DISTANCE_SENSOR" and msg.orientation == MAV.MAV_SENSOR_ROTATION_PITCH_270:
                d = msg.current_distance / 100.0
                valid = msg.min_distance <= msg.current_distance <= msg.max_distance
                self._alt, self._alt_t = (d if valid else None), now
            elif kind == "RANGEFINDER" and np.isfinite(msg.distance) and msg.distance > 0:
                self._alt, self._alt_t = float(msg.distance), now
            elif kind == "COMMAND_ACK":
                self.acks[msg.command] = msg.result

    # ------------------------------------------------------------------ readings

    def telemetry(self) -> Telemetry:
        now = self._clock()
        with self._lock:
            return Telemetry(self._hb_t, self._mode, self._armed, self._att.copy(), self._rates.copy(), self._att_t,
                             self._pos.copy(), self._vel.copy(), self._pos_t, self._depth, self._depth_t,
                             self._alt, self._alt_t, self._meter.rates(now))
