"""ArduSub firmware behaviour for the test peer (:mod:`hal.testing.ardusub_peer`).

Written from ArduSub's own source (4.0.2 and current master: GCS_Mavlink.cpp,
flight_mode.cpp / mode.cpp, control_guided.cpp / mode_guided.cpp, joystick.cpp,
failsafe.cpp, AP_Arming_Sub.cpp, GCS_Common.cpp, GCS_Param.cpp, AP_Baro) and
checked against a 4.0.2 SITL, not from our driver. Two profiles:

* ``4.0``: SET_POSITION_TARGET_LOCAL_NED's yaw and yaw rate are ignored ("for
  future use"); in GUIDED the heading follows auto-yaw (a stale waypoint
  heading: it jumps on entry) until MAV_CMD_CONDITION_YAW sets a heading;
  LOCAL_POSITION_NED is relative to HOME; baro parameters are ``GND_*``;
  a refused mode change is only a COMMAND_ACK (UNSUPPORTED);
* ``4.5``: the setpoint's yaw rate is honoured (and kept, no timeout);
  LOCAL_POSITION_NED is relative to the EKF origin; ``BARO*`` parameters; a
  refused mode change also sends "Mode change failed: Guided requires position".

Common to both: nothing is streamed until requested (SET_MESSAGE_INTERVAL or
REQUEST_DATA_STREAM); GUIDED needs a horizontal position estimate; arming runs
pre-arm checks (failures: STATUSTEXT "PreArm: ..." and ACK FAILED) and moves
HOME to the vehicle (at the surface); GCS HEARTBEATs count only from system 255
(SYSID_MYGCS), and 2.5 s without one disarms an armed vehicle (FS_GCS_ENABLE
default); on hardware (not SITL) 3 s without MANUAL_CONTROL disarms too
(FS_PILOT_INPUT); MANUAL_CONTROL sticks are thrust (fraction = JS_GAIN 0.5 x
stick / 1000) in the pilot modes; guided velocities time out after 3 s.
Vehicle motion is a first-order kinematic model (documented constants below).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from pymavlink import mavutil

MAV = mavutil.mavlink
MANUAL, STABILIZE, ALT_HOLD, GUIDED, SURFACE = 19, 0, 2, 4, 9
PILOT_MODES = (MANUAL, STABILIZE, ALT_HOLD, 1)
KNOWN_MODES = (0, 1, 2, 3, 4, 7, 9, 16, 19)
JS_GAIN = 0.5  # JS_GAIN_DEFAULT
#: Speed at full thrust per axis (surge, sway, heave m/s; yaw rad/s): BlueROV2
#: Heavy order of magnitude (~1.5 m/s forward); a peer constant, not a datasheet value.
FULL_THRUST = (1.5, 1.2, 1.0, 1.5)
TAU = 0.6  # s, first-order response of the vehicle to a thrust or velocity demand
TAU_YAW = 0.3  # s, same for the yaw rate (with the heading gain below: damping ~0.65, no ringing)
YAW_GAIN = 2.0  # 1/s, heading error -> yaw rate demand
YAW_SLEW = math.radians(60.0)  # rad/s, attitude controller heading slew
GUIDED_VEL_TIMEOUT = 3.0  # s (GUIDED_POSVEL_TIMEOUT_MS / GUIDED_VEL_TIMEOUT_MS)
FS_GCS_TIMEOUT = 2.5  # s (FS_GCS_TIMEOUT_MS)
FS_PILOT_TIMEOUT = 3.0  # s (FS_PILOT_TIMEOUT default)
RC_OVERRIDE_TIME = 3.0  # s: sticks go neutral after this without MANUAL_CONTROL
SEABED = 12.0  # m
GROUND_PA = 101325.0
INTERNAL_PA = 98000.0  # enclosure baro
SPEC_GRAV = 1.0
LAT0, LON0 = 44.4056, 8.9463  # Genoa, where MARIS was tested
EARTH_R = 6378137.0
#: REQUEST_DATA_STREAM groups (ArduSub 4.0 GCS_Mavlink.cpp stream tables, the messages this peer knows).
STREAM_GROUPS = {1: (29, 137), 2: (1,), 6: (33, 32), 10: (30,), 11: (74,), 12: (132, 193)}
KNOWN_MSGS = (30, 33, 32, 29, 137, 143, 1, 193, 132, 74, 242, 49, 148)  # 143: SCALED_PRESSURE3 (no third baro fitted)


@dataclass
class Firmware:
    """One ArduSub autopilot; ``send(name, *args)`` emits ``mav.<name>_send(*args)``."""

    profile: str = "4.0"
    position_source: str = "gps"  # gps, dvl or none
    prearm_fail: str | None = None
    hardware: bool = True  # pilot-input failsafe exists (compiled out of SITL)
    boot: float = 0.0
    now: float = 0.0
    armed: bool = False
    mode: int = MANUAL
    streams: dict = field(default_factory=dict)  # msg id -> interval s
    last_sent: dict = field(default_factory=dict)
    gcs_hb_t: float | None = None
    pilot_t: float | None = None
    pilot_failsafe: bool = False
    sticks: tuple = (0, 0, 500, 0)
    pos: list = field(default_factory=lambda: [0.0, 0.0])  # north, east from origin (m)
    depth: float = 0.0
    yaw: float = math.radians(30.0)
    vel: list = field(default_factory=lambda: [0.0, 0.0, 0.0, 0.0])  # vn, ve, vd, yaw rate
    guided_vel: tuple | None = None
    guided_vel_t: float = -1e9
    yaw_mode: str = "hold"  # hold, heading, rate
    yaw_target: float = 0.0
    yaw_rate_cmd: float = 0.0
    home: tuple[float, float] | None = None  # (north, east)
    origin_sent: bool = False
    out: list[tuple[str, tuple[object, ...]]] = field(default_factory=list)
    counts: dict = field(default_factory=dict)

    # ------------------------------------------------------------------ helpers
    def send(self, name: str, *args: object) -> None:
        self.out.append((name, args))

    def text(self, severity: int, text: str) -> None:
        self.send("statustext", severity, text.encode())

    def ack(self, command: int, result: int) -> None:
        self.send("command_ack", command, result)

    def ms(self) -> int:
        return int((self.now - self.boot) * 1000) & 0xFFFFFFFF

    def has_position(self) -> bool:
        return self.position_source in ("gps", "dvl")

    def ekf_flags(self) -> int:
        f = 1 | 32  # attitude, vertical position (depth sensor)
        if self.position_source == "gps":
            f |= 2 | 4 | 8 | 16 | 256 | 512
        elif self.position_source == "dvl":
            f |= 2 | 4 | 8 | 256
        return f

    def latlon(self) -> tuple[int, int]:
        if not self.has_position():
            return 0, 0  # GLOBAL_POSITION_INT is sent anyway, with no position
        lat = LAT0 + math.degrees(self.pos[0] / EARTH_R)
        lon = LON0 + math.degrees(self.pos[1] / (EARTH_R * math.cos(math.radians(LAT0))))
        return int(round(lat * 1e7)), int(round(lon * 1e7))

    # ------------------------------------------------------------------ life cycle
    def reboot(self, now: float) -> None:
        """Power cycle: streams, mode, arming, HOME are lost; the vehicle stays where it is."""
        self.now = self.boot = now
        self.armed, self.mode, self.streams, self.last_sent = False, MANUAL, {}, {}
        self.gcs_hb_t = self.pilot_t = None
        self.pilot_failsafe = False
        self.guided_vel, self.yaw_mode, self.home, self.origin_sent = None, "hold", None, False
        self.vel = [0.0, 0.0, 0.0, 0.0]

    def set_home(self) -> None:
        if self.has_position():
            self.home = (self.pos[0], self.pos[1])  # ArduSub puts HOME at the surface above the vehicle
            lat, lon = self.latlon()
            self.send("home_position", lat, lon, 0, 0, 0, 0, [1, 0, 0, 0], 0, 0, 0)

    # ------------------------------------------------------------------ input
    def handle(self, msg: mavutil.mavlink.MAVLink_message) -> None:  # noqa: C901 - one dispatch per message type
        kind = msg.get_type()
        self.counts[kind] = self.counts.get(kind, 0) + 1
        sysid = msg.get_srcSystem()
        if kind == "HEARTBEAT":
            if sysid == 255:
                self.gcs_hb_t = self.now
        elif kind == "MANUAL_CONTROL":
            if sysid != 255 or msg.target != 1:
                return
            self.sticks, self.pilot_t = (msg.x, msg.y, msg.z, msg.r), self.now
            if self.profile == "4.0":
                self.gcs_hb_t = self.now  # 4.0 counts it as a GCS heartbeat
        elif kind == "COMMAND_LONG":
            if msg.target_system == 1:
                self.command(
                    msg.command, [msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6, msg.param7]
                )
        elif kind == "SET_MODE":
            ok = self.set_mode(int(msg.custom_mode)) if msg.base_mode & 1 else False
            self.ack(11, MAV.MAV_RESULT_ACCEPTED if ok else MAV.MAV_RESULT_UNSUPPORTED)
        elif kind == "REQUEST_DATA_STREAM":
            ids = (
                [m for g in STREAM_GROUPS.values() for m in g]
                if msg.req_stream_id == 0
                else STREAM_GROUPS.get(msg.req_stream_id, ())
            )
            for mid in ids:
                self.set_interval(
                    mid, 1.0 / msg.req_message_rate if msg.start_stop and msg.req_message_rate > 0 else 0.0
                )
        elif kind == "PARAM_REQUEST_READ":
            self.param(msg.param_id)
        elif kind == "SET_POSITION_TARGET_LOCAL_NED":
            self.setpoint(msg)

    def set_interval(self, mid: int, interval: float) -> None:
        if interval <= 0:
            self.streams.pop(mid, None)
        else:
            self.streams[mid] = interval
            self.last_sent.setdefault(mid, -1e9)

    def param(self, name: str) -> None:
        if self.profile == "4.0":
            table = {
                "GND_ABS_PRESS": INTERNAL_PA,
                "GND_ABS_PRESS2": GROUND_PA,
                "GND_SPEC_GRAV": SPEC_GRAV,
                "SYSID_MYGCS": 255,
            }
        else:
            table = {
                "BARO1_GND_PRESS": INTERNAL_PA,
                "BARO2_GND_PRESS": GROUND_PA,
                "BARO_SPEC_GRAV": SPEC_GRAV,
                "SYSID_MYGCS": 255,
            }
        if name in table:  # unknown names get no answer (GCS_Param.cpp)
            self.send("param_value", name.encode(), float(table[name]), MAV.MAV_PARAM_TYPE_REAL32, 1000, 65535)

    def set_mode(self, mode: int) -> bool:
        if mode == self.mode:
            return True
        if mode not in KNOWN_MODES:
            return False
        if mode == GUIDED and not self.has_position():
            if self.profile != "4.0":
                self.text(MAV.MAV_SEVERITY_WARNING, "Mode change failed: Guided requires position")
            return False
        self.mode = mode
        if mode == GUIDED:  # guided_init: position control, default auto-yaw = a stale waypoint heading
            self.guided_vel, self.yaw_mode, self.yaw_target = None, "heading", self.yaw + math.radians(45.0)
        else:
            self.yaw_mode = "hold"
        self.last_sent[0] = -1e9  # gcs().send_message(MSG_HEARTBEAT) right away
        return True

    def command(self, cmd: int, p: list) -> None:  # noqa: C901
        if cmd == MAV.MAV_CMD_DO_SET_MODE:
            ok = int(p[0]) & MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED and self.set_mode(int(p[1]))
            self.ack(cmd, MAV.MAV_RESULT_ACCEPTED if ok else MAV.MAV_RESULT_UNSUPPORTED)
        elif cmd == MAV.MAV_CMD_COMPONENT_ARM_DISARM:
            if p[0] == 1.0:
                if self.armed:
                    self.ack(cmd, MAV.MAV_RESULT_ACCEPTED)
                elif self.prearm_fail and p[1] != 2989.0:
                    self.text(MAV.MAV_SEVERITY_CRITICAL, f"PreArm: {self.prearm_fail}")
                    self.ack(cmd, MAV.MAV_RESULT_FAILED)
                else:
                    self.armed = True
                    if self.home is not None:
                        self.set_home()  # AP_Arming_Sub::arm: HOME moves to the vehicle (not locked)
                    self.last_sent[0] = -1e9
                    self.ack(cmd, MAV.MAV_RESULT_ACCEPTED)
            elif p[0] == 0.0:
                self.armed = False
                self.last_sent[0] = -1e9
                self.ack(cmd, MAV.MAV_RESULT_ACCEPTED)
            else:
                self.ack(cmd, MAV.MAV_RESULT_UNSUPPORTED)
        elif cmd == MAV.MAV_CMD_SET_MESSAGE_INTERVAL:
            mid, us = int(p[0]), p[1]
            if mid not in KNOWN_MSGS and mid != 0:
                self.text(MAV.MAV_SEVERITY_INFO, f"No ap_message for mavlink id ({mid})")
                self.ack(cmd, MAV.MAV_RESULT_FAILED)
                return
            self.set_interval(mid, 0.0 if us < 0 else max(us, 1000.0) / 1e6 if us else 0.0)
            self.ack(cmd, MAV.MAV_RESULT_ACCEPTED)
        elif cmd == MAV.MAV_CMD_REQUEST_MESSAGE:
            mid = int(p[0])
            if mid not in KNOWN_MSGS:
                self.ack(cmd, MAV.MAV_RESULT_FAILED)
                return
            self.ack(cmd, MAV.MAV_RESULT_ACCEPTED)
            self.emit(mid)
        elif cmd == MAV.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
            self.ack(cmd, MAV.MAV_RESULT_ACCEPTED)
            self.emit(148)
        elif cmd == MAV.MAV_CMD_CONDITION_YAW:
            if 0.0 <= p[0] <= 360.0 and p[3] in (0.0, 1.0):
                target = math.radians(p[0])
                if p[3] == 1.0:
                    target = self.yaw_target + math.copysign(target, p[2] or 1.0)
                self.yaw_mode, self.yaw_target = "heading", target
                self.ack(cmd, MAV.MAV_RESULT_ACCEPTED)
            else:
                self.ack(cmd, MAV.MAV_RESULT_FAILED if self.profile == "4.0" else MAV.MAV_RESULT_DENIED)
        else:
            self.ack(cmd, MAV.MAV_RESULT_UNSUPPORTED)

    def setpoint(self, m: mavutil.mavlink.MAVLink_message) -> None:
        if self.mode != GUIDED or m.coordinate_frame not in (1, 7, 8, 9, 12):
            return
        pos_ign, vel_ign, acc_ign = m.type_mask & 7 == 7, m.type_mask & 56 == 56, m.type_mask & 448 == 448
        if not (pos_ign and not vel_ign and acc_ign):
            return  # this peer models the velocity sub-mode only
        vn, ve = m.vx, m.vy
        if m.coordinate_frame in (8, 9, 12):  # body frames: rotated by heading only
            c, s = math.cos(self.yaw), math.sin(self.yaw)
            vn, ve = c * m.vx - s * m.vy, s * m.vx + c * m.vy
        if self.guided_vel is None and self.profile != "4.0":
            self.yaw_mode = "hold"  # guided_vel_control_start: AUTO_YAW_HOLD
            self.yaw_target = self.yaw
        self.guided_vel, self.guided_vel_t = (vn, ve, m.vz), self.now
        if self.profile != "4.0":
            yaw_ign, rate_ign = bool(m.type_mask & 1024), bool(m.type_mask & 2048)
            if not yaw_ign:
                self.yaw_mode, self.yaw_target = "heading", m.yaw
            elif not rate_ign:
                self.yaw_mode, self.yaw_rate_cmd = "rate", m.yaw_rate
            elif self.yaw_mode == "rate":
                self.yaw_mode, self.yaw_target = "hold", self.yaw

    # ------------------------------------------------------------------ time
    def step(self, now: float) -> None:
        dt, self.now = max(0.0, now - self.now), now
        if self.armed and self.gcs_hb_t is not None and now - self.gcs_hb_t > FS_GCS_TIMEOUT:
            self.armed = False
            self.text(MAV.MAV_SEVERITY_WARNING, "MYGCS: 255, heartbeat lost")
        if self.hardware and now - self.boot > FS_PILOT_TIMEOUT:  # failsafe_pilot_input_check: acts once per loss
            if self.pilot_t is not None and now - self.pilot_t < FS_PILOT_TIMEOUT:
                self.pilot_failsafe = False
            elif not self.pilot_failsafe:
                self.pilot_failsafe = True
                self.text(MAV.MAV_SEVERITY_CRITICAL, "Lost manual control")
                self.armed = False
        target = [0.0, 0.0, 0.0, 0.0]
        if self.armed and self.mode in PILOT_MODES:
            sticks = (
                self.sticks if self.pilot_t is not None and now - self.pilot_t < RC_OVERRIDE_TIME else (0, 0, 500, 0)
            )
            frac = [
                JS_GAIN * sticks[0] / 1000,
                JS_GAIN * sticks[1] / 1000,
                -JS_GAIN * (sticks[2] - 500) / 500,
                JS_GAIN * sticks[3] / 1000,
            ]
            c, s = math.cos(self.yaw), math.sin(self.yaw)
            u, v = frac[0] * FULL_THRUST[0], frac[1] * FULL_THRUST[1]
            target = [c * u - s * v, s * u + c * v, frac[2] * FULL_THRUST[2], frac[3] * FULL_THRUST[3]]
        elif self.armed and self.mode == GUIDED:
            if self.guided_vel is not None and now - self.guided_vel_t < GUIDED_VEL_TIMEOUT:
                target[:3] = list(self.guided_vel)
            if self.yaw_mode == "rate":
                target[3] = self.yaw_rate_cmd
            else:
                err = math.atan2(math.sin(self.yaw_target - self.yaw), math.cos(self.yaw_target - self.yaw))
                target[3] = max(-YAW_SLEW, min(YAW_SLEW, YAW_GAIN * err))
        elif self.armed and self.mode == SURFACE:
            target[2] = -0.5
        a = 1.0 - math.exp(-dt / TAU) if dt > 0 else 0.0
        a_yaw = 1.0 - math.exp(-dt / TAU_YAW) if dt > 0 else 0.0
        self.vel = [v + (a_yaw if i == 3 else a) * (t - v) for i, (v, t) in enumerate(zip(self.vel, target))]
        self.pos[0] += self.vel[0] * dt  # the vehicle moves whether or not the EKF knows where it is
        self.pos[1] += self.vel[1] * dt
        self.depth = min(SEABED - 0.2, max(0.0, self.depth + self.vel[2] * dt))
        self.yaw = math.atan2(math.sin(self.yaw + self.vel[3] * dt), math.cos(self.yaw + self.vel[3] * dt))
        if self.has_position() and not self.origin_sent:
            self.origin_sent = True
            self.emit(49)  # "EKF2 IMU0 origin set": GPS_GLOBAL_ORIGIN and HOME go out unasked
            self.set_home()
        self.send_due()

    def send_due(self) -> None:
        hb = self.last_sent.get(0, -1e9)
        if self.now - hb >= 1.0:
            self.last_sent[0] = self.now
            self.emit(0)
        for mid, interval in list(self.streams.items()):
            if self.now - self.last_sent.get(mid, -1e9) >= interval:
                self.last_sent[mid] = self.now
                self.emit(mid)

    def emit(self, mid: int) -> None:  # noqa: C901
        ms = self.ms()
        if mid == 0:
            base = (
                MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | MAV.MAV_MODE_FLAG_STABILIZE_ENABLED | (128 if self.armed else 0)
            )
            self.send(
                "heartbeat",
                MAV.MAV_TYPE_SUBMARINE,
                MAV.MAV_AUTOPILOT_ARDUPILOTMEGA,
                base,
                self.mode,
                MAV.MAV_STATE_ACTIVE if self.armed else MAV.MAV_STATE_STANDBY,
            )
        elif mid == 30:
            self.send("attitude", ms, 0.0, 0.0, self.yaw, 0.0, 0.0, self.vel[3])
        elif mid == 33:
            lat, lon = self.latlon()
            v = self.vel if self.has_position() else [0, 0, 0]
            self.send(
                "global_position_int",
                ms,
                lat,
                lon,
                int(-self.depth * 1000),
                int(-self.depth * 1000),
                int(v[0] * 100),
                int(v[1] * 100),
                int(v[2] * 100),
                int(math.degrees(self.yaw) % 360 * 100),
            )
        elif mid == 32:
            if not self.has_position() or (self.profile == "4.0" and self.home is None):
                return  # no position: LOCAL_POSITION_NED is not sent at all
            ref = self.home if self.profile == "4.0" and self.home is not None else (0.0, 0.0)
            self.send("local_position_ned", ms, self.pos[0] - ref[0], self.pos[1] - ref[1], self.depth, *self.vel[:3])
        elif mid in (29, 137):
            pa = INTERNAL_PA if mid == 29 else GROUND_PA + self.depth * 9800.0 * SPEC_GRAV
            self.send("scaled_pressure" if mid == 29 else "scaled_pressure2", ms, pa / 100.0, 0.0, 2000)
        elif mid == 1:
            sensors = 1 | 2 | 4 | 8 | (1 << 21)
            self.send("sys_status", sensors, sensors, sensors, 200, 16000, -1, -1, 0, 0, 0, 0, 0, 0)
        elif mid == 193:
            self.send("ekf_status_report", self.ekf_flags(), 0.1, 0.1, 0.1, 0.1, 0.0)
        elif mid == 132:
            self.send(
                "distance_sensor",
                ms,
                20,
                5000,
                int((SEABED - self.depth) * 100),
                0,
                1,
                MAV.MAV_SENSOR_ROTATION_PITCH_270,
                0,
            )
        elif mid == 74:
            self.send(
                "vfr_hud", 0.0, 0.0, int(math.degrees(self.yaw)) % 360, 0, 10.0 - self.depth, 0.0
            )  # alt above sea level
        elif mid == 49 and self.has_position():
            self.send("gps_global_origin", int(LAT0 * 1e7), int(LON0 * 1e7), 10000)
        elif mid == 242 and self.home is not None:
            self.set_home()
        elif mid == 148:
            ver = (4 << 24 | 0 << 16 | 2 << 8 | 255) if self.profile == "4.0" else (4 << 24 | 5 << 16 | 1 << 8 | 255)
            self.send("autopilot_version", 0, ver, 0, 0, 0, b"\0" * 8, b"\0" * 8, b"\0" * 8, 0, 0, 0, b"\0" * 18)
