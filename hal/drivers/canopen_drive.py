"""Host side of one CiA 402 drive in profile velocity mode (one arm joint or
one gripper motor group), on a shared :class:`hal.drivers.canbus.CanopenBus`.

Set-up (:meth:`Cia402Drive.configure`, SDO, blocking, done once in ``open``):
producer heartbeat 0x1017, consumer heartbeat 0x1016 watching the host (the
drive faults by itself if the host dies), mode 0x6060 = 3 (profile velocity), rated current
0x6075 read back, PDO mapping

* RPDO1: controlword 0x6040 + target velocity 0x60FF,
* TPDO1: statusword 0x6041 + velocity actual 0x606C,
* TPDO2: position actual 0x6064 + current actual 0x6078 (per mille of 0x6075),

both TPDOs asynchronous with an event timer, then NMT start.

Run time (:meth:`service`, called by the bus thread every period): heartbeat
watchdog, one CiA 402 step towards :attr:`target_state` (see
:func:`hal.drivers.cia402.next_command`), RPDO1 out. Readings arrive in the
canopen notifier thread and are stamped with the backend clock on arrival.

Safety: :meth:`request_safe_state` leads the drive down through QUICK STOP
ACTIVE to SWITCH ON DISABLED; a fault reset is only sent when the owner asks for
OPERATION ENABLED again (:meth:`request_enable`).

Units: positions rad, velocities rad/s (joint side) through ``counts_per_rad``
and ``velocity_units_per_rad_s``; currents A.
"""

from __future__ import annotations

import logging
import struct
import threading
import time
from dataclasses import dataclass
from typing import Callable

import canopen

from hal.drivers.cia402 import CONTROLWORD, State, decode_statusword, next_command
from hal.interfaces import Health, HealthState

log = logging.getLogger(__name__)

PROFILE_VELOCITY_MODE = 3
NMT_STATES = {0x00: "INITIALISING", 0x04: "STOPPED", 0x05: "OPERATIONAL", 0x7F: "PRE-OPERATIONAL"}
#: Time (s) a quick stop may take before voltage is disabled anyway.
QUICK_STOP_TIMEOUT = 1.0
#: Below this speed (rad/s) a quick stop counts as done.
STOPPED_SPEED = 1e-3
#: Time (s) a fault reset may take before the drive counts as faulted again.
FAULT_RESET_TIMEOUT = 0.5
#: Time (s) a drive may take after NMT start to show OPERATIONAL heartbeat and PDOs.
START_TIMEOUT = 1.0


class DriveError(RuntimeError):
    """A drive could not be set up (no SDO answer, object missing, ...)."""


@dataclass(frozen=True)
class DriveParams:
    node_id: int
    counts_per_rad: float
    velocity_units_per_rad_s: float
    max_velocity: float  # rad/s
    heartbeat_period: float = 0.05  # s
    heartbeat_timeout: float = 0.3  # s
    pdo_period: float = 0.01  # s
    stale_timeout: float = 0.2  # s
    host_node_id: int = 127  # our heartbeat producer ID, watched by the drive
    host_heartbeat_timeout: float = 0.5  # s, the drive faults when our heartbeat is older (0: not watched)


@dataclass(frozen=True)
class DriveReading:
    """Latest values of one drive; times on the backend clock (s), None if never received."""

    t_status: float | None
    t_position: float | None
    state: State | None
    statusword: int
    position: float  # rad
    velocity: float  # rad/s
    current: float  # A
    nmt: str
    heartbeat_t: float | None
    error_code: int  # last EMCY error code, 0 if none


class Cia402Drive:
    """One CiA 402 drive; thread-safe, non-blocking after :meth:`configure`."""

    def __init__(self, network: canopen.Network, eds: str, params: DriveParams, clock: Callable[[], float], name: str) -> None:
        self.name = name
        self.params = params
        self._clock = clock
        self._network = network
        self.node = canopen.RemoteNode(params.node_id, eds)
        network.add_node(self.node)
        self._lock = threading.Lock()
        self._target_velocity = 0.0  # rad/s
        self._target_state = State.SWITCH_ON_DISABLED
        self._last_cw = 0
        self._quick_stop_since: float | None = None
        self._rated_current_a = 1.0
        self._sw = 0
        self._state: State | None = None
        self._t_status: float | None = None
        self._t_position: float | None = None
        self._position = 0.0
        self._velocity = 0.0
        self._current = 0.0
        self._nmt = "UNKNOWN"
        self._hb_t: float | None = None
        self._error_code = 0
        self._configured = False
        self._fault_latched: str | None = None
        self._reset_started: float | None = None
        self._reset_requested = False
        network.subscribe(0x700 + params.node_id, self._on_heartbeat)
        network.subscribe(0x80 + params.node_id, self._on_emcy)

    # ------------------------------------------------------------------ set-up

    def configure(self) -> None:
        """SDO set-up and NMT start (blocking, ~tens of ms). Raises DriveError."""
        p = self.params
        try:
            self.node.nmt.send_command(0x80)  # to PRE-OPERATIONAL: PDO mapping may only change there
            self.node.sdo[0x1017].raw = max(1, int(round(p.heartbeat_period * 1000)))
            self._watch_host(p)
            self.node.sdo[0x6060].raw = PROFILE_VELOCITY_MODE
            self.node.sdo[0x60FF].raw = 0
            self._rated_current_a = self.node.sdo[0x6075].raw / 1000.0
            event_ms = max(1, int(round(p.pdo_period * 1000)))
            rp = self.node.rpdo[1]
            rp.clear()
            rp.cob_id = 0x200 + p.node_id
            rp.add_variable(0x6040)
            rp.add_variable(0x60FF)
            rp.trans_type = 255
            rp.enabled = True
            for num, objs in ((1, (0x6041, 0x606C)), (2, (0x6064, 0x6078))):
                tp = self.node.tpdo[num]
                tp.clear()
                tp.cob_id = (0x180 if num == 1 else 0x280) + p.node_id
                for obj in objs:
                    tp.add_variable(obj)
                tp.trans_type = 255
                tp.event_timer = event_ms
                tp.enabled = True
                tp.add_callback(self._on_tpdo)
            rp.save()
            self.node.tpdo[1].save()
            self.node.tpdo[2].save()
            mode = self.node.sdo[0x6061].raw
            if mode != PROFILE_VELOCITY_MODE:
                raise DriveError(f"{self.name} (node {p.node_id}): drive reports mode {mode}, wanted profile velocity (3)")
        except (canopen.SdoCommunicationError, canopen.SdoAbortedError) as exc:
            raise DriveError(f"{self.name} (node {p.node_id}): set-up failed: {exc}") from exc
        self._set_rpdo(0, 0)
        self.node.nmt.send_command(0x01)  # start: OPERATIONAL
        self._configured = True
        self._wait_operational(max(START_TIMEOUT, 3 * p.heartbeat_period))

    def _wait_operational(self, timeout: float) -> None:
        """Block (bounded) until the drive's heartbeat says OPERATIONAL and its TPDOs flow."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            r = self.reading()
            if r.nmt == "OPERATIONAL" and r.t_status is not None and r.t_position is not None:
                return
            time.sleep(0.005)
        r = self.reading()
        raise DriveError(f"{self.name} (node {self.params.node_id}): not operational {timeout:.1f} s after NMT start "
                         f"(NMT {r.nmt}, status PDO {'seen' if r.t_status is not None else 'missing'})")

    def _watch_host(self, p: DriveParams) -> None:
        """Ask the drive to consume our heartbeat (0x1016:1 = node ID << 16 | ms), if it can."""
        if 0x1016 not in self.node.object_dictionary or p.host_heartbeat_timeout <= 0:
            log.warning("%s: EDS has no 0x1016; the drive will not notice a dead host", self.name)
            return
        self.node.sdo[0x1016][1].raw = (p.host_node_id << 16) | max(1, int(round(p.host_heartbeat_timeout * 1000)))

    # ------------------------------------------------------------------ commands (any thread)

    def set_velocity(self, qdot: float) -> None:
        """Target velocity (rad/s), clipped to ``max_velocity``; NaN counts as 0."""
        v = float(qdot)
        if v != v:
            v = 0.0
        lim = self.params.max_velocity
        with self._lock:
            self._target_velocity = min(lim, max(-lim, v))

    def request_enable(self) -> None:
        """Bring the drive to OPERATION ENABLED (through a fault reset if faulted)."""
        with self._lock:
            self._target_state = State.OPERATION_ENABLED
            self._fault_latched = None
            self._quick_stop_since = None
            self._reset_started = None
            self._reset_requested = True

    def request_safe_state(self) -> None:
        """Zero velocity, quick stop, then SWITCH ON DISABLED."""
        with self._lock:
            self._target_velocity = 0.0
            self._target_state = State.SWITCH_ON_DISABLED

    @property
    def target_state(self) -> State:
        return self._target_state

    def resetting(self, now: float) -> bool:
        """True while a fault reset asked by :meth:`request_enable` is still in progress."""
        with self._lock:
            if not self._reset_requested or self._state not in (State.FAULT, State.FAULT_REACTION_ACTIVE, None):
                return False
            return self._reset_started is None or now - self._reset_started < FAULT_RESET_TIMEOUT

    # ------------------------------------------------------------------ periodic service (bus thread)

    def service(self, now: float) -> None:
        if not self._configured:
            return
        fault = self.fault_text(now)
        with self._lock:
            if self._state == State.OPERATION_ENABLED:
                self._reset_requested = False
            if self._reset_requested and self._state == State.FAULT and fault and "CiA 402" in fault:
                # the owner asked to enable a faulted drive: give the fault reset a moment
                if self._reset_started is None:
                    self._reset_started = now
                if now - self._reset_started < FAULT_RESET_TIMEOUT:
                    fault = None
            if fault and self._target_state == State.OPERATION_ENABLED:
                log.warning("%s: %s -> safe state", self.name, fault)
                self._fault_latched = fault
                self._target_state = State.SWITCH_ON_DISABLED
                self._target_velocity = 0.0
            state = self._state
            target = self._target_state
            vel = self._target_velocity if state == State.OPERATION_ENABLED and target == State.OPERATION_ENABLED else 0.0
            cw = self._controlword(state, target, now)
        self._set_rpdo(cw, int(round(vel * self.params.velocity_units_per_rad_s)))

    def _controlword(self, state: State | None, target: State, now: float) -> int:
        if state is None:
            return self._last_cw
        if state == State.QUICK_STOP_ACTIVE and target != State.OPERATION_ENABLED:
            if self._quick_stop_since is None:
                self._quick_stop_since = now
            stopped = abs(self._velocity) < STOPPED_SPEED
            if not stopped and now - self._quick_stop_since < QUICK_STOP_TIMEOUT:
                return CONTROLWORD["quick_stop"]
        else:
            self._quick_stop_since = None
        if state == State.FAULT and target != State.OPERATION_ENABLED:
            return 0x00  # a fault is only reset when the owner asks to enable again
        cmd = next_command(state, target)
        if cmd is None:  # there already (or in FAULT REACTION ACTIVE): hold the matching word
            return {State.OPERATION_ENABLED: 0x0F, State.SWITCHED_ON: 0x07, State.READY_TO_SWITCH_ON: 0x06}.get(state, 0x00)
        cw = CONTROLWORD[cmd]
        if cmd == "fault_reset" and self._last_cw & 0x80:
            cw = 0x00  # bit 7 must go low again before the next rising edge
        return cw

    def _set_rpdo(self, cw: int, velocity_units: int) -> None:
        self._last_cw = cw
        try:
            self._network.send_message(0x200 + self.params.node_id, struct.pack("<Hi", cw, velocity_units))
        except Exception as exc:  # noqa: BLE001 - a send error shows up as stale data / lost heartbeat
            log.debug("%s: RPDO send failed: %s", self.name, exc)

    # ------------------------------------------------------------------ receive (notifier thread)

    def _on_tpdo(self, pdo_map: canopen.pdo.PdoMap) -> None:
        now = self._clock()
        values = {var.index: var.raw for var in pdo_map}
        with self._lock:
            if 0x6041 in values:
                self._sw = int(values[0x6041])
                self._state = decode_statusword(self._sw)
                if self._state not in (State.FAULT, State.FAULT_REACTION_ACTIVE):
                    self._error_code = 0
                self._velocity = values.get(0x606C, 0) / self.params.velocity_units_per_rad_s
                self._t_status = now
            if 0x6064 in values:
                self._position = values[0x6064] / self.params.counts_per_rad
                self._current = values.get(0x6078, 0) / 1000.0 * self._rated_current_a
                self._t_position = now

    def _on_heartbeat(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if data:
            with self._lock:
                self._nmt = NMT_STATES.get(data[0] & 0x7F, f"0x{data[0]:02X}")
                self._hb_t = self._clock()

    def _on_emcy(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if len(data) >= 2:
            with self._lock:
                self._error_code = int.from_bytes(data[0:2], "little")

    # ------------------------------------------------------------------ readings

    def reading(self) -> DriveReading:
        with self._lock:
            return DriveReading(self._t_status, self._t_position, self._state, self._sw, self._position,
                                self._velocity, self._current, self._nmt, self._hb_t, self._error_code)

    def fault_text(self, now: float) -> str | None:
        """Why this drive is not usable right now, or None."""
        p = self.params
        r = self.reading()
        where = f"{self.name} (node {p.node_id})"
        if r.heartbeat_t is None:
            return f"{where}: no heartbeat received"
        if now - r.heartbeat_t > p.heartbeat_timeout:
            return f"{where}: heartbeat lost ({now - r.heartbeat_t:.2f} s, limit {p.heartbeat_timeout:.2f} s)"
        if r.nmt != "OPERATIONAL":
            return f"{where}: NMT state {r.nmt}"
        if r.state in (State.FAULT, State.FAULT_REACTION_ACTIVE):
            code = f", error code 0x{r.error_code:04X}" if r.error_code else ""
            return f"{where}: CiA 402 {r.state.value}{code}"
        for t, what in ((r.t_status, "statusword"), (r.t_position, "position")):
            if t is None:
                return f"{where}: no {what} PDO received"
            if now - t > p.stale_timeout:
                return f"{where}: stale {what} PDO ({now - t:.2f} s old)"
        return None

    def health(self, now: float) -> Health:
        r = self.reading()
        info = {
            "name": self.name,
            "node_id": self.params.node_id,
            "nmt": r.nmt,
            "cia402": r.state.value if r.state else "unknown",
            "statusword": f"0x{r.statusword:04X}",
            "heartbeat_age_s": None if r.heartbeat_t is None else round(now - r.heartbeat_t, 3),
        }
        fault = self.fault_text(now)
        if r.heartbeat_t is None and r.t_status is None:
            return Health(HealthState.MISSING, now, fault or "", info)
        if fault:
            return Health(HealthState.FAULT, now, fault, info)
        if self._fault_latched:
            return Health(HealthState.FAULT, now, f"{self._fault_latched} (cleared; enable to resume)", info)
        return Health(HealthState.OK, now, "", info)

    def close(self) -> None:
        self._configured = False
        try:
            self._network.unsubscribe(0x700 + self.params.node_id, self._on_heartbeat)
            self._network.unsubscribe(0x80 + self.params.node_id, self._on_emcy)
        except Exception:  # noqa: BLE001
            pass
