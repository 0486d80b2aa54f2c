"""What a ground station knows about an ArduSub autopilot, built from its messages.

Pure state, no I/O: :class:`ArdusubState` is fed every decoded message
(:meth:`ArdusubState.handle`) with the backend time of arrival, and answers
:meth:`ArdusubState.snapshot`. Facts of the firmware it relies on (read in
ArduSub's and GCS_MAVLink's source, 4.0 and current master):

* nothing but HEARTBEAT (plus HOME_POSITION / GPS_GLOBAL_ORIGIN / TIMESYNC when
  they change) is streamed until asked: every ``SRn_*`` rate defaults to 0;
* LOCAL_POSITION_NED is relative to HOME in 4.0 (to the EKF origin later), and
  HOME moves to the vehicle at every arming; so the world position here is
  GLOBAL_POSITION_INT (lat/lon, which never re-anchor) in metres north/east of a
  fixed anchor: the first EKF origin (GPS_GLOBAL_ORIGIN) seen, logged once;
* GLOBAL_POSITION_INT is sent even without a position (stale or zero): the
  position counts only while EKF_STATUS_REPORT reports a horizontal position;
* depth is the depth sensor's own reading: ArduSub computes it as
  (pressure - ground pressure) / (9800 Pa/m x BARO_SPEC_GRAV); pressure from
  SCALED_PRESSURE[2|3] (hPa), ground pressure from the GND_ABS_PRESS[n] (4.0)
  or BAROn_GND_PRESS (4.1+) parameter, in Pa, specific gravity GND_/BARO_SPEC_GRAV. VFR_HUD's altitude is above sea
  level and is not used;
* AUTOPILOT_VERSION.flight_sw_version = major << 24 | minor << 16 | patch << 8 | type.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from pymavlink import mavutil

MAV = mavutil.mavlink
SUB_MODES: dict[int, str] = dict(mavutil.mode_mapping_sub)
SUB_MODE_IDS: dict[str, int] = {v: k for k, v in SUB_MODES.items()}
EARTH_RADIUS_M = 6378137.0  # WGS-84 equatorial radius; flat-earth offsets over a dive site
ORIGIN_WAIT_S = 3.0  # s a valid position waits for GPS_GLOBAL_ORIGIN before anchoring on itself
WATER_PA_PER_M = 9800.0  # ArduSub's own constant (AP_Baro: pressure difference / 9800 / spec. gravity)

#: EKF_STATUS_REPORT flag bits (ardupilotmega EKF_STATUS_FLAGS), named for reports.
EKF_FLAGS = {
    1: "attitude",
    2: "velocity_horiz",
    4: "velocity_vert",
    8: "pos_horiz_rel",
    16: "pos_horiz_abs",
    32: "pos_vert_abs",
    64: "pos_vert_agl",
    128: "const_pos_mode",
    256: "pred_pos_horiz_rel",
    512: "pred_pos_horiz_abs",
    1024: "uninitialized",
    32768: "gps_glitching",
}
EKF_HAS_POSITION = 8 | 16
EKF_VELOCITY = 2 | 4

#: SYS_STATUS sensor bits worth naming when unhealthy.
SENSOR_NAMES = {
    1: "gyro",
    2: "accel",
    4: "mag",
    8: "pressure",
    16: "diff_pressure",
    32: "gps",
    64: "optical_flow",
    256: "laser_position",
    1024: "angular_rate_control",
    2048: "attitude_stabilization",
    4096: "yaw_position",
    8192: "z_altitude_control",
    16384: "xy_position_control",
    32768: "motor_outputs",
    65536: "rc_receiver",
    1 << 21: "ahrs",
    1 << 23: "logging",
    1 << 24: "battery",
    1 << 25: "proximity",
    1 << 28: "prearm_check",
}

RESULT_NAMES = {
    0: "ACCEPTED",
    1: "TEMPORARILY_REJECTED",
    2: "DENIED",
    3: "UNSUPPORTED",
    4: "FAILED",
    5: "IN_PROGRESS",
    6: "CANCELLED",
}

PRESSURE_MSGS = ("SCALED_PRESSURE", "SCALED_PRESSURE2", "SCALED_PRESSURE3")
#: Ground-pressure parameter of each baro instance: ArduSub 4.0 names (baro group
#: prefix ``GND_``, checked against a 4.0.2 SITL), then the 4.1+ names.
GROUND_PRESSURE_PARAMS = (
    ("GND_ABS_PRESS", "BARO1_GND_PRESS"),
    ("GND_ABS_PRESS2", "BARO2_GND_PRESS"),
    ("GND_ABS_PRESS3", "BARO3_GND_PRESS"),
)
SPEC_GRAV_PARAMS = ("GND_SPEC_GRAV", "BARO_SPEC_GRAV")


def ned_offset(lat: float, lon: float, lat0: float, lon0: float) -> tuple[float, float]:
    """North, east (m) of (lat, lon) from (lat0, lon0), degrees; flat earth (a dive site is small)."""
    north = math.radians(lat - lat0) * EARTH_RADIUS_M
    east = math.radians(lon - lon0) * EARTH_RADIUS_M * math.cos(math.radians(lat0))
    return north, east


def decode_version(flight_sw_version: int) -> tuple[int, int, int, str]:
    """(major, minor, patch, release type) from AUTOPILOT_VERSION.flight_sw_version."""
    v = int(flight_sw_version)
    kind = {0: "dev", 64: "alpha", 128: "beta", 192: "rc", 255: "official"}.get(v & 0xFF, f"type {v & 0xFF}")
    return (v >> 24) & 0xFF, (v >> 16) & 0xFF, (v >> 8) & 0xFF, kind


def flag_names(bits: int, names: dict[int, str]) -> list[str]:
    return [n for b, n in names.items() if bits & b]


class RateMeter:
    """Message rates (Hz) as arrivals counted over a fixed window, so a burst of
    buffered messages after a stall does not read as a high rate."""

    def __init__(self, window: float = 4.0) -> None:
        self.window = window
        self._times: dict[str, deque[float]] = {}
        self._since: float | None = None

    def reset(self, now: float) -> None:
        self._times.clear()
        self._since = now

    def tick(self, name: str, t: float) -> None:
        if self._since is None:
            self._since = t
        q = self._times.setdefault(name, deque())
        q.append(t)
        while q and q[0] < t - self.window:
            q.popleft()

    def rates(self, now: float) -> dict[str, float | None]:
        """Messages per second of each kind (None while the first seconds are measured)."""
        span = min(self.window, max(1e-3, now - (self._since if self._since is not None else now)))
        out: dict[str, float | None] = {}
        cut = now - self.window
        for k, q in self._times.items():
            n = len(q)  # in arrival order, pruned at each tick: only the oldest few can be out of the window
            for t in q:
                if t >= cut:
                    break
                n -= 1
            out[k] = round(n / span, 1) if span >= 1.0 else None  # None: still measuring
        return out


class StatusText(NamedTuple):
    """A STATUSTEXT message of the autopilot: when it came (s), its severity, its text."""

    t: float
    severity: int
    text: str


class NavFields(NamedTuple):
    """The navigation part of :class:`Telemetry` (same meanings and units)."""

    attitude: np.ndarray
    rates: np.ndarray
    attitude_t: float | None
    position: np.ndarray
    velocity_ned: np.ndarray | None
    velocity_t: float | None
    depth: float | None
    altitude: float | None


@dataclass(frozen=True)
class Telemetry:
    """A snapshot of the autopilot; every ``*_t`` is the backend time (s) of arrival, None if never.

    position: world NED (m) from the fixed anchor, z = depth; NaN where unknown.
    attitude rad (roll, pitch, yaw), rates rad/s, velocity_ned m/s (None unknown).
    """

    heartbeat_t: float | None
    mode: str
    armed: bool
    system_status: int | None
    version: str | None
    version_tuple: tuple[int, int, int] | None
    attitude: np.ndarray
    rates: np.ndarray
    attitude_t: float | None
    position: np.ndarray
    position_t: float | None
    velocity_ned: np.ndarray | None
    velocity_t: float | None
    depth: float | None
    depth_t: float | None
    altitude: float | None
    altitude_t: float | None
    ekf_flags: int | None
    anchor: tuple[float, float] | None
    anchor_source: str | None
    unhealthy_sensors: list[str]
    rates_hz: dict[str, float | None]
    statustexts: list[StatusText]
    depth_source: str | None


@dataclass
class _Baro:
    pressure_pa: float | None = None
    t: float | None = None


@dataclass
class ArdusubState:
    """Mutable autopilot state. ``target_system``: only its messages count.
    ``depth_sensor``: 1..3 (SCALED_PRESSURE[n]) or 0 = auto (the highest instance seen)."""

    target_system: int = 1
    depth_sensor: int = 0
    heartbeat_t: float | None = None
    mode: str = "UNKNOWN"
    custom_mode: int | None = None
    armed: bool = False
    system_status: int | None = None
    version: str | None = None
    version_tuple: tuple[int, int, int] | None = None
    attitude: np.ndarray = field(default_factory=lambda: np.full(3, np.nan))
    rates: np.ndarray = field(default_factory=lambda: np.full(3, np.nan))
    attitude_t: float | None = None
    boot_ms: int | None = None
    lat_lon: tuple[float, float] | None = None
    lat_lon_t: float | None = None
    velocity_ned: np.ndarray | None = None
    velocity_t: float | None = None
    ekf_flags: int | None = None
    ekf_t: float | None = None
    origin: tuple[float, float] | None = None
    home: tuple[float, float] | None = None
    anchor: tuple[float, float] | None = None
    anchor_source: str | None = None
    first_fix_t: float | None = None
    params: dict = field(default_factory=dict)
    baros: list = field(default_factory=lambda: [_Baro(), _Baro(), _Baro()])
    altitude: float | None = None
    altitude_t: float | None = None
    sensors_present: int = 0
    sensors_health: int = 0
    statustexts: deque[StatusText] = field(default_factory=lambda: deque(maxlen=40))
    acks: deque = field(default_factory=lambda: deque(maxlen=40))
    meter: RateMeter = field(default_factory=RateMeter)
    rebooted: bool = False  # set when the boot time went backwards; the link clears it
    notes: list = field(default_factory=list)  # one-off log lines for the link to emit

    # ------------------------------------------------------------------ input
    def handle(self, msg: mavutil.mavlink.MAVLink_message, now: float) -> None:  # noqa: C901 - one dispatch on message type
        kind = msg.get_type()
        if msg.get_srcSystem() != self.target_system:
            return
        if kind == "HEARTBEAT":
            if msg.type != MAV.MAV_TYPE_SUBMARINE or msg.autopilot == MAV.MAV_AUTOPILOT_INVALID:
                return  # a camera, gimbal or another GCS on the same link
            self.meter.tick(kind, now)
            self.heartbeat_t = now
            self.armed = bool(msg.base_mode & MAV.MAV_MODE_FLAG_SAFETY_ARMED)
            self.custom_mode = int(msg.custom_mode)
            self.mode = SUB_MODES.get(msg.custom_mode, f"mode {msg.custom_mode}")
            self.system_status = int(msg.system_status)
            return
        self.meter.tick(kind, now)
        boot = getattr(msg, "time_boot_ms", None)
        if boot is not None:
            if self.boot_ms is not None and boot + 5000 < self.boot_ms:
                self.rebooted = True
                self.notes.append(f"autopilot rebooted (boot time {self.boot_ms} -> {boot} ms)")
            self.boot_ms = int(boot)
        if kind == "ATTITUDE":
            att = np.array([msg.roll, msg.pitch, msg.yaw])
            rates = np.array([msg.rollspeed, msg.pitchspeed, msg.yawspeed])
            if np.all(np.isfinite(att)) and np.all(np.isfinite(rates)):
                self.attitude, self.rates, self.attitude_t = att, rates, now
        elif kind == "GLOBAL_POSITION_INT":
            self.lat_lon, self.lat_lon_t = (msg.lat * 1e-7, msg.lon * 1e-7), now
        elif kind == "LOCAL_POSITION_NED":
            vel = np.array([msg.vx, msg.vy, msg.vz])
            if np.all(np.isfinite(vel)):
                self.velocity_ned, self.velocity_t = vel, now
        elif kind == "EKF_STATUS_REPORT":
            self.ekf_flags, self.ekf_t = int(msg.flags), now
        elif kind == "GPS_GLOBAL_ORIGIN":
            self.origin = (msg.latitude * 1e-7, msg.longitude * 1e-7)
            self._set_anchor(self.origin, "EKF origin")
        elif kind == "HOME_POSITION":
            self.home = (msg.latitude * 1e-7, msg.longitude * 1e-7)
        elif kind in PRESSURE_MSGS:
            i = PRESSURE_MSGS.index(kind)
            if math.isfinite(msg.press_abs) and msg.press_abs > 0:
                self.baros[i] = _Baro(float(msg.press_abs) * 100.0, now)
        elif kind == "PARAM_VALUE":
            self.params[msg.param_id] = float(msg.param_value)
        elif kind == "DISTANCE_SENSOR" and msg.orientation == MAV.MAV_SENSOR_ROTATION_PITCH_270:
            valid = msg.min_distance <= msg.current_distance <= msg.max_distance and msg.current_distance > 0
            self.altitude, self.altitude_t = (msg.current_distance / 100.0 if valid else None), now
        elif kind == "SYS_STATUS":
            self.sensors_present = int(msg.onboard_control_sensors_present)
            self.sensors_health = int(msg.onboard_control_sensors_health) | ~int(msg.onboard_control_sensors_enabled)
        elif kind == "STATUSTEXT":
            self.statustexts.append(StatusText(now, int(msg.severity), str(msg.text).rstrip("\x00")))
        elif kind == "COMMAND_ACK":
            self.acks.append((now, int(msg.command), int(msg.result)))
        elif kind == "AUTOPILOT_VERSION":
            major, minor, patch, rel = decode_version(msg.flight_sw_version)
            self.version_tuple = (major, minor, patch)
            self.version = f"ArduSub {major}.{minor}.{patch} ({rel})"

    def _set_anchor(self, latlon: tuple[float, float], source: str) -> None:
        if self.anchor is not None:
            return
        self.anchor, self.anchor_source = latlon, source
        self.notes.append(
            f"world frame fixed: origin at lat {latlon[0]:.7f}, lon {latlon[1]:.7f} ({source}); "
            "positions are metres north/east of it and depth below the surface; "
            "ArduSub's HOME (moved at every arming) is not used"
        )

    # ------------------------------------------------------------------ derived
    def has_position(self) -> bool:
        """True while the EKF reports a horizontal position (absolute or relative) and not const-pos mode."""
        f = self.ekf_flags
        return f is not None and bool(f & EKF_HAS_POSITION) and not f & 128

    def depth_instance(self) -> int | None:
        """0-based baro instance used for depth, None if none reported yet."""
        if self.depth_sensor:
            return self.depth_sensor - 1
        seen = [i for i, b in enumerate(self.baros) if b.t is not None]
        return seen[-1] if seen else None

    def ground_pressure_pa(self, i: int) -> float | None:
        for name in GROUND_PRESSURE_PARAMS[i]:
            v = self.params.get(name)
            if v is not None and v > 0:
                return v
        return None

    def spec_grav(self) -> float | None:
        for name in SPEC_GRAV_PARAMS:
            if self.params.get(name) is not None:
                return self.params[name]
        return None

    def depth(self) -> tuple[float | None, float | None, str | None]:
        """(depth m, time, source) from the depth sensor, as ArduSub computes it."""
        i = self.depth_instance()
        if i is None:
            return None, None, None
        b = self.baros[i]
        ground = self.ground_pressure_pa(i)
        sg = self.spec_grav()
        src = f"{PRESSURE_MSGS[i]} with {'/'.join(GROUND_PRESSURE_PARAMS[i])}"
        if b.pressure_pa is None or ground is None or sg is None or sg <= 0:
            return None, None, src
        return (b.pressure_pa - ground) / (WATER_PA_PER_M * sg), b.t, src

    def position(self, depth: float | None, now: float) -> tuple[np.ndarray, float | None]:
        """World NED position (NaN where unknown) and its time. Without a reported
        EKF origin, the anchor falls back to the first valid position after
        ``ORIGIN_WAIT_S`` (the origin was asked for meanwhile)."""
        pos = np.full(3, np.nan)
        t = None
        if self.lat_lon is not None and self.has_position():
            if self.first_fix_t is None:
                self.first_fix_t = now
            if self.anchor is None and now - self.first_fix_t >= ORIGIN_WAIT_S:
                self._set_anchor(self.lat_lon, "first valid position (no EKF origin reported)")
        if self.lat_lon is not None and self.has_position() and self.anchor is not None:
            pos[0], pos[1] = ned_offset(*self.lat_lon, *self.anchor)
            t = self.lat_lon_t
        if depth is not None:
            pos[2] = depth
        return pos, t

    def unhealthy(self) -> list[str]:
        bad = self.sensors_present & ~self.sensors_health
        return flag_names(bad, SENSOR_NAMES)

    def nav_fields(self, now: float) -> NavFields:
        """What :meth:`ArdusubVehicle.navigation` uses of :meth:`snapshot`, the same values
        (and side effects: the anchor fallback of :meth:`position`) without the rest
        (rates, messages, health): called every control step."""
        depth, depth_t, _src = self.depth()
        pos, _pos_t = self.position(depth, now)
        ned = self.velocity_ned if self.ekf_flags is not None and self.ekf_flags & 2 else None
        vel = ned.copy() if ned is not None else None
        att, rates = self.attitude.copy(), self.rates.copy()
        for a in (att, rates, pos, vel):  # shared by every reader until the next message: never written
            if a is not None:
                a.flags.writeable = False
        return NavFields(
            att, rates, self.attitude_t, pos, vel, self.velocity_t if ned is not None else None, depth, self.altitude
        )

    def snapshot(self, now: float) -> Telemetry:
        depth, depth_t, depth_src = self.depth()
        pos, pos_t = self.position(depth, now)
        ned = self.velocity_ned if self.ekf_flags is not None and self.ekf_flags & 2 else None
        return Telemetry(
            self.heartbeat_t,
            self.mode,
            self.armed,
            self.system_status,
            self.version,
            self.version_tuple,
            self.attitude.copy(),
            self.rates.copy(),
            self.attitude_t,
            pos,
            pos_t,
            ned.copy() if ned is not None else None,
            self.velocity_t if ned is not None else None,
            depth,
            depth_t,
            self.altitude,
            self.altitude_t,
            self.ekf_flags,
            self.anchor,
            self.anchor_source,
            self.unhealthy(),
            self.meter.rates(now),
            list(self.statustexts),
            depth_src,
        )
