"""MAVLink link to an ArduSub autopilot, behaving as a careful ground station.

:class:`ArdusubLink` owns a :class:`~hal.drivers.mavlink_transport.Transport`
and two threads:

* io: opens the link (TCP/UDP/serial), sends our GCS HEARTBEAT (system 255 by
  default, the ``SYSID_MYGCS`` ArduSub listens to) the instant it is open,
  decodes everything into :class:`~hal.drivers.ardusub_state.ArdusubState`,
  and on loss closes and reopens with back-off (0.5 s doubling to 5 s; one log
  line per state change, never a busy loop);
* tx: HEARTBEAT at 1 Hz; stream requests (ArduSub streams nothing until asked:
  SET_MESSAGE_INTERVAL per message, REQUEST_DATA_STREAM as fallback), repeated
  after a reconnect, an autopilot reboot or while a needed stream is missing;
  AUTOPILOT_VERSION, origin and the depth-sensor parameters until known; the
  motion command at 10 Hz, only while the vehicle is armed in the wanted mode.

Commands (:meth:`ArdusubLink.set_mode`, :meth:`ArdusubLink.set_armed`) block
until confirmed by the COMMAND_ACK *and* the next HEARTBEAT, or return the
refusal reason: the ACK result and every STATUSTEXT since the request.

Motion paths (``command``):

* ``setpoint`` (GUIDED): SET_POSITION_TARGET_LOCAL_NED velocities in
  MAV_FRAME_BODY_OFFSET_NED (ArduSub rotates them by heading only; w is along
  NED down). Heading, by firmware version (AUTOPILOT_VERSION):
  4.1 and later honour the yaw rate of the setpoint (``yaw_path``
  ``setpoint_yaw_rate``); 4.0 ignores it ("for future use" in its source) and
  steers the heading by auto-yaw, so the yaw-rate reference is integrated into
  a heading target sent as MAV_CMD_CONDITION_YAW (``yaw_path`` ``condition_yaw``,
  also used when the version is unknown). Neutral MANUAL_CONTROL is sent at
  4 Hz as well: on a real ArduSub (not SITL) no pilot input for FS_PILOT_TIMEOUT
  (3 s) disarms the vehicle (FS_PILOT_INPUT default).
* ``manual_control`` (open-loop fallback, explicitly configured): MANUAL_CONTROL
  sticks, which ArduSub maps to thrust (fraction = JS_GAIN x stick / 1000), not
  velocity. ``full_stick`` gives the speed (m/s, rad/s) the vehicle reaches at
  full stick, measured on the real vehicle; stick = reference / full_stick.

Nothing here blocks a control tick: :meth:`set_velocity` only stores a value.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from hal.drivers.ardusub_state import (
    GROUND_PRESSURE_PARAMS,
    MAV,
    PRESSURE_MSGS,
    RESULT_NAMES,
    SPEC_GRAV_PARAMS,
    SUB_MODE_IDS,
    ArdusubState,
    NavFields,
    Telemetry,
)
from hal.drivers.mavlink_transport import LinkDown, MavCodec, Transport
from hal.drivers.realtime import STEP_GATE

log = logging.getLogger(__name__)

SETPOINT_RATE = 10.0  # Hz
COMMAND_TIMEOUT = 0.5  # s: a reference older than this is replaced by zero
VEL_ONLY_MASK = 0x0DC7  # ignore position, acceleration, yaw and yaw rate: velocities only (4.0 path)
VEL_YAWRATE_MASK = 0x05C7  # ignore position, acceleration, yaw: velocities + yaw rate (4.1+ path)
YAW_LEAD_MAX = 0.5  # rad: the 4.0 heading target never leads the measured heading by more
BACKOFF = (0.5, 1.0, 2.0, 4.0, 5.0)  # s between reconnect attempts
#: Messages the driver asks for and their rate (Hz).
STREAMS: dict[int, float] = {
    30: 20.0,  # ATTITUDE
    33: 10.0,  # GLOBAL_POSITION_INT
    32: 10.0,  # LOCAL_POSITION_NED (velocity)
    29: 10.0,
    137: 10.0,
    143: 10.0,  # SCALED_PRESSURE, 2, 3 (depth sensor)
    1: 2.0,  # SYS_STATUS
    193: 2.0,  # EKF_STATUS_REPORT
    132: 5.0,  # DISTANCE_SENSOR
}
#: REQUEST_DATA_STREAM fallback (stream id, Hz) for firmware without SET_MESSAGE_INTERVAL.
LEGACY_STREAMS = ((1, 10), (2, 2), (6, 10), (10, 20), (12, 5))
#: Streams whose absence is reported (name -> what it is for).
REQUIRED = {"ATTITUDE": "attitude", "SYS_STATUS": "sensor health", "EKF_STATUS_REPORT": "EKF status"}
MANUAL_MODES = ("MANUAL", "STABILIZE", "ALT_HOLD", "ACRO")


def manual_control_axes(sp: np.ndarray, full_stick: tuple[float, float, float, float]) -> tuple[int, int, int, int]:
    """MANUAL_CONTROL x, y, z, r for a reference [u, v, w, r] (m/s, rad/s).

    Stick = reference / full-stick speed, clipped to +-1000; z is 0..1000 with
    500 neutral and up positive, so w (positive down) lowers it."""

    def stick(value: float, full: float) -> int:
        return int(round(float(np.clip(value / full, -1.0, 1.0)) * 1000))

    return (
        stick(sp[0], full_stick[0]),
        stick(sp[1], full_stick[1]),
        500 - stick(sp[2], full_stick[2]) // 2,
        stick(sp[3], full_stick[3]),
    )


def wrap_pi(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


class HeadingSent(NamedTuple):
    """The last heading sent to the autopilot (rad) and when (``time.monotonic()``, s)."""

    heading: float
    mono: float


class ArdusubLink:
    """Connection to one ArduSub autopilot. ``clock`` gives the backend time (s)."""

    def __init__(
        self,
        url: str,
        clock: Callable[[], float],
        *,
        baudrate: int = 115200,
        source_system: int = 255,
        target_system: int = 1,
        arm_mode: str = "GUIDED",
        command: str = "setpoint",
        max_speed: float = 1.0,
        max_yaw_rate: float = 0.5,
        depth_sensor: int = 0,
        full_stick: tuple[float, float, float, float] | None = None,
        heartbeat_timeout: float = 3.0,
    ) -> None:
        if arm_mode not in SUB_MODE_IDS:
            raise ValueError(f"unknown ArduSub mode {arm_mode!r}; known: {', '.join(SUB_MODE_IDS)}")
        if command not in ("setpoint", "manual_control"):
            raise ValueError(f"unknown command kind {command!r}")
        if command == "manual_control" and full_stick is None:
            raise ValueError("command: manual_control needs the measured full-stick speeds (manual_full_stick)")
        self.url = url
        self._clock = clock
        self.target_system = target_system
        self.target_component = 1
        self.arm_mode = arm_mode
        self.command = command
        self.max_speed = max_speed
        self.max_yaw_rate = max_yaw_rate
        self.full_stick = full_stick
        self.heartbeat_timeout = heartbeat_timeout
        self._transport = Transport(url, baudrate)
        self._codec = MavCodec(self._transport.write, source_system, MAV.MAV_COMP_ID_MISSIONPLANNER)
        self.state = ArdusubState(target_system=target_system, depth_sensor=depth_sensor)
        self._lock = threading.RLock()
        self._send_lock = threading.Lock()
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._nav: NavFields | None = None  # ArdusubState.nav_fields as of the last message (io thread)
        self._setpoint = np.zeros(4)  # u, v, w, r
        self._setpoint_t = -math.inf
        self._engaged = False  # armed in arm_mode by us: motion commands may flow
        self._yaw_ref: float | None = None
        self._yaw_rate_prev = 0.0
        self._yaw_sent: HeadingSent | None = None
        self.link_state = "closed"
        self.link_error = ""
        self._streams_t: float | None = None  # monotonic time of the last stream request
        self._info_t = -math.inf
        self._hb_was_fresh = False
        self.yaw_path = "condition_yaw"
        self.connected_once = False
        self.open_attempts = 0  # transport opens tried (back-off bounds them)

    # ------------------------------------------------------------------ life cycle
    def connect(self) -> None:
        """Start the threads; the link opens in the background (see :attr:`link_state`)."""
        if self._threads:
            return
        self._stop.clear()
        for target, name in ((self._io_loop, "mavlink-io"), (self._tx_loop, "mavlink-tx")):
            th = threading.Thread(target=target, name=name, daemon=True)
            th.start()
            self._threads.append(th)

    def close(self) -> None:
        """Zero the motion command, stop the threads, close the link. Idempotent."""
        if not self._threads:
            return
        self.set_velocity(np.zeros(6))
        self._send_motion(force=True)
        self._stop.set()
        for th in self._threads:
            th.join(timeout=2.0)
        self._threads.clear()
        self._transport.shutdown()
        self._set_link("closed")

    def _set_link(self, state: str, error: str = "") -> None:
        if state != self.link_state or (error and error != self.link_error):
            if state == "connected":
                log.info("ArduSub link %s: connected", self.url)
            elif state == "retrying":
                log.warning("ArduSub link %s: %s; retrying with back-off (up to %.0f s)", self.url, error, BACKOFF[-1])
        self.link_state, self.link_error = state, error

    # ------------------------------------------------------------------ threads
    def _io_loop(self) -> None:
        attempt = 0
        while not self._stop.is_set():
            if not self._transport.is_open:
                self.open_attempts += 1
                try:
                    self._transport.open(timeout=1.0)
                except LinkDown as exc:
                    self._set_link("retrying", str(exc))
                    self._stop.wait(BACKOFF[min(attempt, len(BACKOFF) - 1)])
                    attempt += 1
                    continue
                attempt = 0
                self._set_link("connected")
                self.connected_once = True
                self._heartbeat()  # from the first instant: ArduSub disarms without it (FS_GCS)
                self._streams_t = None
            try:
                data = self._transport.read(0.05)
            except LinkDown as exc:
                self._transport.close()
                self._set_link("retrying", f"link lost ({exc})")
                self._stop.wait(BACKOFF[0])
                continue
            if data:
                now = self._clock()  # stamped on arrival: the gate's wait counts as latency
                STEP_GATE.wait()  # decode after the control loop's step, not during it
                msgs = self._codec.parse(data)
                with self._lock:
                    for m in msgs:
                        self.state.handle(m, now)
                    if msgs:
                        self._nav = self.state.nav_fields(now)  # published for the control step
                    for note in self.state.notes:
                        log.info("ArduSub %s: %s", self.url, note)
                    self.state.notes.clear()

    def _tx_loop(self) -> None:
        next_hb = next_motion = next_keepalive = 0.0
        while not self._stop.wait(0.02):
            if not self._transport.is_open:
                continue
            STEP_GATE.wait()
            mono = time.monotonic()
            if mono >= next_hb:
                next_hb = mono + 1.0
                self._heartbeat()
            self._maintain(mono)
            if mono >= next_motion:
                next_motion = mono + 1.0 / SETPOINT_RATE
                self._send_motion()
            with self._lock:
                sticks_idle = self.command == "setpoint" or not self._motion_allowed()
            if sticks_idle and mono >= next_keepalive:  # neutral sticks: ArduSub's pilot-input failsafe
                next_keepalive = mono + 0.25
                self._send(lambda m: m.manual_control_send(self.target_system, 0, 0, 500, 0, 0))

    def _heartbeat(self) -> None:
        self._send(lambda m: m.heartbeat_send(MAV.MAV_TYPE_GCS, MAV.MAV_AUTOPILOT_INVALID, 0, 0, MAV.MAV_STATE_ACTIVE))

    def _send(self, fn: Callable) -> None:
        with self._send_lock:
            try:
                fn(self._codec.mav)
            except (OSError, ValueError) as exc:  # a lost link shows up in the io thread
                log.debug("MAVLink send failed: %s", exc)

    def _maintain(self, mono: float) -> None:
        """Ask for what the autopilot does not send by itself, again after a reboot or reconnect."""
        now = self._clock()
        with self._lock:
            st = self.state
            fresh = st.heartbeat_t is not None and now - st.heartbeat_t < self.heartbeat_timeout
            if fresh and not self._hb_was_fresh:
                self._streams_t = None  # heartbeat back after a silence: the autopilot may have restarted
            self._hb_was_fresh = fresh
            if st.rebooted:
                st.rebooted = False
                self._streams_t = None
                st.meter.reset(now)
            if not fresh:
                return
            rates = st.meter.rates(now)
            missing = [n for n in ("ATTITUDE", "EKF_STATUS_REPORT") if rates.get(n, 0.0) == 0.0]
            due = self._streams_t is None or (missing and mono - self._streams_t > 3.0)
            need_info = (
                st.version is None
                or st.origin is None
                or st.spec_grav() is None
                or all(st.ground_pressure_pa(i) is None for i in range(3))
            )
        if due:
            if self._streams_t is None:
                log.info("ArduSub %s: requesting telemetry streams (ArduSub sends none until asked)", self.url)
            retry = self._streams_t is not None
            if retry:
                log.warning(
                    "ArduSub %s: no %s after requesting it; asking again (also with REQUEST_DATA_STREAM)",
                    self.url,
                    ", ".join(missing),
                )
            self._streams_t = mono
            with self._lock:
                st.meter.reset(now)
            for msg_id, hz in STREAMS.items():
                self.command_long(MAV.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6 / hz, wait=None)
            for stream, hz in LEGACY_STREAMS if retry else ():  # firmware without SET_MESSAGE_INTERVAL
                self._send(
                    lambda m, s=stream, r=hz: m.request_data_stream_send(
                        self.target_system, self.target_component, s, r, 1
                    )
                )
        if need_info and mono - self._info_t > 2.0:
            self._info_t = mono
            self._request_info()

    def streams_requested_s(self) -> float | None:
        """Seconds since the telemetry streams were last requested (None: not yet)."""
        return None if self._streams_t is None else time.monotonic() - self._streams_t

    def _request_info(self) -> None:
        st = self.state
        if st.version is None:
            self.command_long(MAV.MAV_CMD_REQUEST_MESSAGE, 148, wait=None)  # AUTOPILOT_VERSION
            self.command_long(MAV.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 1, wait=None)  # older firmware
        if st.origin is None:
            self.command_long(MAV.MAV_CMD_REQUEST_MESSAGE, 49, wait=None)  # GPS_GLOBAL_ORIGIN
        names = list(SPEC_GRAV_PARAMS) + [n for pair in GROUND_PRESSURE_PARAMS for n in pair]
        for name in names:
            if name not in st.params:
                self._send(
                    lambda m, n=name: m.param_request_read_send(
                        self.target_system, self.target_component, n.encode(), -1
                    )
                )

    # ------------------------------------------------------------------ commands
    def command_long(self, command: int, *params: float, wait: float | None = 2.0, tries: int = 2) -> int | None:
        """Send COMMAND_LONG; with ``wait`` (s), return the COMMAND_ACK result (None: no answer)."""
        p = list(params) + [0.0] * (7 - len(params))
        for attempt in range(tries if wait else 1):
            t_sent = self._clock()
            self._send(
                lambda m, c=attempt: m.command_long_send(self.target_system, self.target_component, command, c, *p)
            )
            if not wait:
                return None
            deadline = time.monotonic() + wait / tries
            while time.monotonic() < deadline:
                with self._lock:
                    for t, cmd, result in reversed(self.state.acks):
                        if cmd == command and t >= t_sent and result != MAV.MAV_RESULT_IN_PROGRESS:
                            return result
                time.sleep(0.01)
        return None

    def _texts_since(self, t: float) -> list[str]:
        with self._lock:
            return [text for (tt, _sev, text) in self.state.statustexts if tt >= t]

    def _wait_heartbeat(self, pred: Callable[[ArdusubState], bool], after: float, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self._lock:
                if self.state.heartbeat_t is not None and self.state.heartbeat_t >= after and pred(self.state):
                    return True
            time.sleep(0.02)
        return False

    def set_mode(self, mode: str, timeout: float = 3.0) -> str | None:
        """Switch flight mode; None when confirmed, else why not (ACK result, STATUSTEXTs)."""
        mode_id = SUB_MODE_IDS[mode]
        with self._lock:
            if self.state.custom_mode == mode_id:
                return None
        t0 = self._clock()
        result = self.command_long(
            MAV.MAV_CMD_DO_SET_MODE, MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode_id, wait=timeout
        )
        if result == MAV.MAV_RESULT_ACCEPTED and self._wait_heartbeat(lambda s: s.custom_mode == mode_id, t0, timeout):
            return None
        return self._refusal(f"mode {mode}", result, t0)

    def set_armed(self, armed: bool, timeout: float = 4.0) -> str | None:
        """Arm or disarm; None when the HEARTBEAT confirms it, else why not."""
        t0 = self._clock()
        result = self.command_long(MAV.MAV_CMD_COMPONENT_ARM_DISARM, 1.0 if armed else 0.0, wait=timeout)
        if result == MAV.MAV_RESULT_ACCEPTED and self._wait_heartbeat(lambda s: s.armed == armed, t0, timeout):
            return None
        return self._refusal("arming" if armed else "disarming", result, t0)

    def _refusal(self, what: str, result: int | None, t0: float) -> str:
        texts = self._texts_since(t0)
        if result is None:
            why = f"ArduSub did not answer the {what} request (no COMMAND_ACK)"
        elif result == MAV.MAV_RESULT_ACCEPTED:
            why = f"ArduSub accepted {what} but its HEARTBEAT never confirmed it"
        else:
            why = f"ArduSub refused {what} (COMMAND_ACK {RESULT_NAMES.get(result, result)})"
        if texts:
            why += ": " + "; ".join(f'"{t}"' for t in texts)
        return why

    def engage(self) -> None:
        """Start streaming motion commands (call once armed in ``arm_mode``)."""
        with self._lock:
            vt = self.state.version_tuple
            self.yaw_path = "setpoint_yaw_rate" if vt is not None and vt[:2] >= (4, 1) else "condition_yaw"
            yaw = float(self.state.attitude[2])
            self._yaw_ref = yaw if math.isfinite(yaw) else None
            self._yaw_sent = None
            self._setpoint[:] = 0.0
            self._engaged = True
        if self.command == "setpoint" and self.yaw_path == "condition_yaw" and self._yaw_ref is not None:
            self._send_heading(self._yaw_ref, time.monotonic())

    def disengage(self) -> None:
        with self._lock:
            self._setpoint[:] = 0.0
        self._send_motion(force=True)
        with self._lock:
            self._engaged = False

    @property
    def engaged(self) -> bool:
        return self._engaged

    def set_velocity(self, v: np.ndarray) -> None:
        """Body velocity reference (6,) [u v w p q r]; p, q ignored; clipped; non-finite -> zero."""
        self.set_velocity_values(np.asarray(v, dtype=float).reshape(6).tolist())

    def set_velocity_values(self, v: list[float]) -> None:
        """:meth:`set_velocity` of six plain floats (every control step: no numpy on six values)."""
        if len(v) != 6:
            raise ValueError(f"expected 6 velocity values [u v w p q r], got {len(v)}")
        if not all(map(math.isfinite, v)):
            v = [0.0] * 6
        ms, mr = self.max_speed, self.max_yaw_rate
        sp = np.array(
            (min(ms, max(-ms, v[0])), min(ms, max(-ms, v[1])), min(ms, max(-ms, v[2])), min(mr, max(-mr, v[5])))
        )
        t = self._clock()
        with self._lock:
            self._setpoint = sp
            self._setpoint_t = t

    def _motion_allowed(self) -> bool:
        st = self.state
        return self._engaged and st.armed and st.mode == self.arm_mode

    def _send_motion(self, force: bool = False) -> None:
        """The motion command of this tick: only while armed in the wanted mode (``force``: zero now)."""
        with self._lock:
            allowed = self._motion_allowed()
            if force and not (allowed or self._engaged):
                return  # never armed in the wanted mode by us: send no motion command at all
            fresh = self._clock() - self._setpoint_t < COMMAND_TIMEOUT
            sp = self._setpoint.copy() if fresh and allowed and not force else np.zeros(4)
            yaw_meas = float(self.state.attitude[2])
        if self.command == "manual_control":
            if (allowed or force) and self.full_stick is not None:  # set for manual_control (checked at init)
                x, y, z, r = manual_control_axes(sp, self.full_stick)
                self._send(lambda m: m.manual_control_send(self.target_system, x, y, z, r, 0))
            return
        if not allowed and not force:
            return
        boot_ms = int(self._clock() * 1000) & 0xFFFFFFFF
        if self.yaw_path == "setpoint_yaw_rate":
            mask, yaw_rate = VEL_YAWRATE_MASK, sp[3]
        else:
            mask, yaw_rate = VEL_ONLY_MASK, 0.0
        self._send(
            lambda m: m.set_position_target_local_ned_send(
                boot_ms,
                self.target_system,
                self.target_component,
                MAV.MAV_FRAME_BODY_OFFSET_NED,
                mask,
                0,
                0,
                0,
                sp[0],
                sp[1],
                sp[2],
                0,
                0,
                0,
                0,
                yaw_rate,
            )
        )
        if self.yaw_path == "condition_yaw" and allowed and self._yaw_ref is not None and math.isfinite(yaw_meas):
            if abs(sp[3]) < 1e-3 and abs(self._yaw_rate_prev) >= 1e-3:
                ref = yaw_meas  # the turn is over: hold the heading reached, not the lead target
            else:
                ref = self._yaw_ref + sp[3] / SETPOINT_RATE
            self._yaw_rate_prev = float(sp[3])
            err = wrap_pi(ref - yaw_meas)
            ref = yaw_meas + float(np.clip(err, -YAW_LEAD_MAX, YAW_LEAD_MAX))
            self._yaw_ref = wrap_pi(ref)
            mono = time.monotonic()
            last = self._yaw_sent
            if last is None or abs(wrap_pi(self._yaw_ref - last.heading)) > math.radians(0.5) or mono - last.mono > 1.0:
                self._send_heading(self._yaw_ref, mono)

    def _send_heading(self, heading: float, mono: float) -> None:
        """MAV_CMD_CONDITION_YAW: absolute heading (deg 0..360), default turn rate, shortest way."""
        deg = math.degrees(heading) % 360.0
        with self._lock:
            cur = float(self.state.attitude[2])
        direction = 1.0 if not math.isfinite(cur) or wrap_pi(heading - cur) >= 0 else -1.0
        self._yaw_sent = HeadingSent(heading, mono)
        self.command_long(MAV.MAV_CMD_CONDITION_YAW, deg, 0.0, direction, 0.0, wait=None)

    # ------------------------------------------------------------------ readings
    def telemetry(self) -> Telemetry:
        now = self._clock()
        with self._lock:
            return self.state.snapshot(now)

    def nav_fields(self) -> NavFields:
        """The navigation part of :meth:`telemetry` (read-only arrays), as of the last
        message: built by the io thread when messages arrive, read here without the lock
        (every control step)."""
        nav = self._nav
        if nav is None:
            now = self._clock()
            with self._lock:
                nav = self._nav = self.state.nav_fields(now)
        return nav

    def last_ack(self, command: int) -> int | None:
        with self._lock:
            for _t, cmd, result in reversed(self.state.acks):
                if cmd == command:
                    return result
        return None

    def pressure_streams(self) -> list[str]:
        with self._lock:
            return [PRESSURE_MSGS[i] for i, b in enumerate(self.state.baros) if b.t is not None]
