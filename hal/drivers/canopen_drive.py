"""Host side of one CiA 402 drive in profile velocity mode (one arm joint or
one gripper motor group), on a shared :class:`hal.drivers.canbus.CanopenBus`.

Construction reads and checks the drive's EDS (:mod:`hal.drivers.canopen_od`:
a file it cannot use is an :class:`EdsError` naming device, node and file).
Set-up (:meth:`Cia402Drive.configure`, SDO, blocking, done once in ``connect``)
is :func:`hal.drivers.canopen_setup.configure_drive`, then NMT start.

Run time (:meth:`service`, called by the bus thread every period): heartbeat
watchdog, one CiA 402 step towards :attr:`target_state` (see
:func:`hal.drivers.cia402.next_command`), the RPDO(s) out. Readings arrive in the
canopen notifier thread and are stamped with the backend clock on arrival.

Freshness: a drive sending with an event timer or on SYNC must deliver its
TPDOs within ``stale_timeout``. A drive sending **on change** says nothing
while its values are constant (e.g. steady motion: constant velocity and
statusword); its last values then stay current as long as its heartbeat is
fresh and it is OPERATIONAL, so their time is that of the last heartbeat.

Safety: :meth:`request_safe_state` leads the drive down through QUICK STOP
ACTIVE to SWITCH ON DISABLED; a fault is only reset when the owner asks for it
(:meth:`request_enable`, :meth:`request_fault_reset`). Fault texts carry the
EMCY code and error register, decoded (:mod:`hal.drivers.canopen_emcy`).

Units: positions rad, velocities rad/s (joint side) through ``counts_per_rad``
and ``velocity_units_per_rad_s``; currents A (NaN when the drive has no
current reading or no rated current is known).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import NamedTuple

import canopen

from hal.drivers.canopen_emcy import describe_emcy, parse_emcy
from hal.drivers.canopen_od import EdsError, load_drive_od
from hal.drivers.canopen_setup import DriveError, DriveSetup, configure_drive, read_fault, release_drive
from hal.drivers.cia402 import CONTROLWORD, State, decode_statusword, next_command
from hal.interfaces import Health, HealthState

__all__ = ["Cia402Drive", "DriveError", "DriveParams", "DriveReading", "EdsError"]

log = logging.getLogger(__name__)

NMT_STATES = {0x00: "INITIALISING", 0x04: "STOPPED", 0x05: "OPERATIONAL", 0x7F: "PRE-OPERATIONAL"}
#: Time (s) a quick stop may take before voltage is disabled anyway.
QUICK_STOP_TIMEOUT = 1.0
#: Below this speed (rad/s) a quick stop counts as done.
STOPPED_SPEED = 1e-3
#: Time (s) a fault reset may take before the drive counts as faulted again.
FAULT_RESET_TIMEOUT = 0.5
#: Time (s) a drive may take after NMT start to show OPERATIONAL heartbeat and PDOs.
START_TIMEOUT = 1.0
#: SDO answer timeout (s) and re-sends of a request (set-up writes are idempotent):
#: a busy drive (or bus) may answer late; a missing one is reported after ~1.5 s.
SDO_TIMEOUT = 0.5
SDO_RETRIES = 2


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
    transmission: str = "auto"  # TPDOs: auto, event_timer, on_change, sync (see canopen_setup)
    sync_period: float | None = None  # s, SYNC period of the bus (None: no SYNC producer)
    rated_current_a: float | None = None  # A, used when the EDS has no 0x6075


@dataclass(frozen=True)
class DriveReading:
    """Latest values of one drive; times on the backend clock (s), None if never received."""

    t_status: float | None
    t_position: float | None
    state: State | None
    statusword: int
    position: float  # rad
    velocity: float  # rad/s
    current: float  # A (NaN if unknown)
    nmt: str
    heartbeat_t: float | None
    error_code: int  # last EMCY error code, 0 if none
    error_register: int | None = None


class JointValues(NamedTuple):
    """What the control step reads of one drive (:meth:`Cia402Drive.joint_values`)."""

    position: float  # rad
    velocity: float  # rad/s
    current: float  # A
    #: Backend time (s) of the position reading, None before the first.
    t_position: float | None
    #: The drive can be commanded now (else :meth:`Cia402Drive.problem` says why).
    usable: bool


class Cia402Drive:
    """One CiA 402 drive; thread-safe, non-blocking after :meth:`configure`.

    ``where`` names it in messages (e.g. ``arm joint j2``)."""

    def __init__(
        self,
        network: canopen.Network,
        eds: str,
        params: DriveParams,
        clock: Callable[[], float],
        name: str,
        where: str | None = None,
    ) -> None:
        self.name = name
        self.params = params
        self.where = f"{where or name} (node {params.node_id})"
        self._clock = clock
        self._network = network
        self.od = load_drive_od(eds, params.node_id, where or name)  # EdsError for unusable files
        self.node = canopen.RemoteNode(params.node_id, self.od.od)
        self.node.sdo.RESPONSE_TIMEOUT = SDO_TIMEOUT
        self.node.sdo.MAX_RETRIES = SDO_RETRIES
        network.add_node(self.node)
        self.setup: DriveSetup | None = None
        self._lock = threading.Lock()
        self._target_velocity = 0.0  # rad/s
        self._target_state = State.SWITCH_ON_DISABLED
        self._last_cw = 0
        self._quick_stop_since: float | None = None
        self._rated_current_a: float | None = None
        self._sw = 0
        self._state: State | None = None
        self._t_status: float | None = None
        self._t_position: float | None = None
        self._position = 0.0
        self._velocity = 0.0
        self._current = float("nan")
        self._nmt = "UNKNOWN"
        self._hb_t: float | None = None
        self._error_code = 0
        self._error_register: int | None = None
        self._configured = False
        self._on_change = False
        self._fault_latched: str | None = None
        self._reset_started: float | None = None
        self._reset_requested = False
        self._reset_target = State.OPERATION_ENABLED
        #: (t_status, t_position, state, position, velocity, current, nmt, heartbeat_t): replaced
        #: whole (one reference swap, under the lock) whenever one of them changes, so the
        #: control step reads them without the lock (:meth:`joint_values`).
        self._live: tuple = (None, None, None, 0.0, 0.0, float("nan"), "UNKNOWN", None)
        network.subscribe(0x700 + params.node_id, self._on_heartbeat)
        network.subscribe(0x80 + params.node_id, self._on_emcy)

    # ------------------------------------------------------------------ set-up

    def configure(self) -> None:
        """SDO set-up and NMT start (blocking, ~tens of ms). Raises DriveError."""
        setup = configure_drive(self.node, self.od, self.params, self.where, self._on_tpdo)
        self.setup = setup
        now = self._clock()
        with self._lock:
            self._rated_current_a = setup.rated_current_a
            self._on_change = setup.transmission == "on_change"
            self._apply_values(setup.initial, now)
            if setup.error_code is not None:
                self._error_code = setup.error_code
            self._error_register = setup.error_register
        self._set_rpdo(0, 0)
        self.node.nmt.send_command(0x01)  # start: OPERATIONAL
        self._configured = True
        self._wait_operational(max(START_TIMEOUT, 3 * self.params.heartbeat_period))

    def _wait_operational(self, timeout: float) -> None:
        """Block (bounded) until the heartbeat says OPERATIONAL and (periodic modes) TPDOs flow."""
        deadline = time.monotonic() + timeout
        t_start = self._clock()
        while time.monotonic() < deadline:
            r = self.reading()
            pdo_ok = self._on_change or (
                r.t_status is not None
                and r.t_status >= t_start
                and r.t_position is not None
                and r.t_position >= t_start
            )
            if r.nmt == "OPERATIONAL" and pdo_ok and not (self._on_change and self._still_booting()):
                return
            time.sleep(0.005)
        r = self.reading()
        raise DriveError(
            f"{self.where}: not operational {timeout:.1f} s after NMT start "
            f"(NMT {r.nmt}, status PDO {'seen' if r.t_status and r.t_status >= t_start else 'missing'}, "
            f"transmission {self.setup.transmission if self.setup else '?'})"
        )

    def _still_booting(self) -> bool:
        """True while the drive reports NOT READY TO SWITCH ON (its power-up self-test).

        A drive that sends only on change may leave that state between our SDO read
        at set-up and the moment its PDOs start; the new statusword then never comes
        by PDO (nothing changes afterwards), so it is read here over SDO (blocking,
        only during set-up)."""
        if self._state not in (State.NOT_READY_TO_SWITCH_ON, None):
            return False
        try:
            sw = int(self.node.sdo[0x6041].raw)
        except Exception:  # noqa: BLE001 - a missed read is retried by the caller's loop
            return True
        with self._lock:
            self._apply_values({0x6041: sw}, self._clock())
        return self._state in (State.NOT_READY_TO_SWITCH_ON, None)

    def release(self) -> None:
        """Clean close (drive already disabled): it stops watching our heartbeat and goes
        PRE-OPERATIONAL, so the next session finds it without a fault."""
        if not self._configured:
            return
        self._configured = False
        hb = self.reading().heartbeat_t
        alive = hb is not None and self._clock() - hb <= self.params.heartbeat_timeout
        release_drive(self.node, self.od, self.where, alive)

    # ------------------------------------------------------------------ commands (any thread)

    def set_velocity(self, qdot: float) -> None:
        """Target velocity (rad/s), clipped to ``max_velocity``; NaN counts as 0."""
        v = float(qdot)
        if v != v:
            v = 0.0
        lim = self.params.max_velocity
        with self._lock:
            self._target_velocity = min(lim, max(-lim, v))

    def request_enable(self, reset_fault: bool = False) -> None:
        """Bring the drive to OPERATION ENABLED.

        A drive in FAULT stays there (and counts as faulted again) unless
        ``reset_fault``: a fault is only reset when its owner asks for it, never
        as a side effect of enabling (one that appears between preflight and
        engagement must stop the run, not be cleared by it)."""
        with self._lock:
            self._target_state = State.OPERATION_ENABLED
            if reset_fault:
                self._request_reset(State.OPERATION_ENABLED)
            else:
                self._fault_latched = None
                self._quick_stop_since = None
                self._reset_requested = False

    def request_fault_reset(self) -> None:
        """Reset a drive fault and stay in SWITCH ON DISABLED (not enabled)."""
        with self._lock:
            self._target_state = State.SWITCH_ON_DISABLED
            self._request_reset(State.SWITCH_ON_DISABLED)

    def _request_reset(self, target: State) -> None:
        self._fault_latched = None
        self._quick_stop_since = None
        self._reset_started = None
        self._reset_requested = True
        self._reset_target = target

    def request_safe_state(self) -> None:
        """Zero velocity, quick stop, then SWITCH ON DISABLED."""
        with self._lock:
            self._target_velocity = 0.0
            self._target_state = State.SWITCH_ON_DISABLED
            self._reset_requested = False

    @property
    def target_state(self) -> State:
        return self._target_state

    def resetting(self, now: float) -> bool:
        """True while a fault reset asked for (:meth:`request_enable` with ``reset_fault``,
        :meth:`request_fault_reset`) is still in progress."""
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
            if self._reset_requested and self._state not in (State.FAULT, State.FAULT_REACTION_ACTIVE, None):
                self._reset_requested = False
            if self._reset_requested and self._state == State.FAULT and fault and "CiA 402" in fault:
                # the owner asked for a fault reset: give it a moment
                if self._reset_started is None:
                    self._reset_started = now
                if now - self._reset_started < FAULT_RESET_TIMEOUT:
                    fault = None
            if fault and self._target_state == State.OPERATION_ENABLED:
                log.warning("%s -> safe state", fault)
                self._fault_latched = fault
                self._target_state = State.SWITCH_ON_DISABLED
                self._target_velocity = 0.0
            state = self._state
            target = self._target_state
            vel = (
                self._target_velocity if state == State.OPERATION_ENABLED and target == State.OPERATION_ENABLED else 0.0
            )
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
        if state == State.FAULT and not self._reset_requested:
            return 0x00  # a fault is only reset when the owner asks for it
        if state == State.FAULT:  # fault reset acts on the rising edge of bit 7: alternate 0x80 / 0x00
            return 0x00 if self._last_cw & 0x80 else CONTROLWORD["fault_reset"]
        cmd = next_command(state, target)
        if cmd is None:  # there already (or in FAULT REACTION ACTIVE): hold the matching word
            return {State.OPERATION_ENABLED: 0x0F, State.SWITCHED_ON: 0x07, State.READY_TO_SWITCH_ON: 0x06}.get(
                state, 0x00
            )
        return CONTROLWORD[cmd]

    def _set_rpdo(self, cw: int, velocity_units: int) -> None:
        self._last_cw = cw
        if self.setup is None:
            return
        try:
            for rp in self.setup.rpdos:
                for var in rp:
                    if var.index == 0x6040:
                        var.raw = cw
                    elif var.index == 0x60FF:
                        var.raw = velocity_units
                rp.transmit()
        except Exception as exc:  # noqa: BLE001 - a send error shows up as stale data / lost heartbeat
            log.debug("%s: RPDO send failed: %s", self.where, exc)

    # ------------------------------------------------------------------ receive (notifier thread)

    def _on_tpdo(self, pdo_map: canopen.pdo.PdoMap) -> None:
        now = self._clock()
        values = {var.index: var.raw for var in pdo_map}
        with self._lock:
            self._apply_values(values, now)

    def _apply_values(self, values: Mapping[int, int | float | str | bytes], now: float) -> None:
        """Store received object values (caller holds the lock): the statusword, velocity,
        position and current, integers by the data types the EDS check requires."""
        if 0x6041 in values:
            self._sw = int(values[0x6041])
            self._state = decode_statusword(self._sw)
            if self._state not in (State.FAULT, State.FAULT_REACTION_ACTIVE):
                self._error_code = 0
                self._error_register = None
            self._t_status = now
        if 0x606C in values:
            self._velocity = int(values[0x606C]) / self.params.velocity_units_per_rad_s
        if 0x6064 in values:
            self._position = int(values[0x6064]) / self.params.counts_per_rad
            self._t_position = now
        if 0x6078 in values and self._rated_current_a is not None:
            self._current = int(values[0x6078]) / 1000.0 * self._rated_current_a
        self._publish()

    def _publish(self) -> None:
        """Swap in the new :attr:`_live` tuple (caller holds the lock)."""
        self._live = (
            self._t_status,
            self._t_position,
            self._state,
            self._position,
            self._velocity,
            self._current,
            self._nmt,
            self._hb_t,
        )

    def _on_heartbeat(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if data:
            with self._lock:
                self._nmt = NMT_STATES.get(data[0] & 0x7F, f"0x{data[0]:02X}")
                self._hb_t = self._clock()
                self._publish()

    def _on_emcy(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if len(data) >= 2:
            code, register = parse_emcy(data)
            with self._lock:
                if code:
                    self._error_code, self._error_register = code, register
            if code:
                log.warning("%s: %s", self.where, describe_emcy(code, register))

    # ------------------------------------------------------------------ readings

    def reading(self) -> DriveReading:
        with self._lock:
            t_status, t_position = self._t_status, self._t_position
            if self._on_change and self._nmt == "OPERATIONAL" and self._hb_t is not None:
                # on change: constant values stay current while the drive is alive (heartbeat)
                t_status = None if t_status is None else max(t_status, self._hb_t)
                t_position = None if t_position is None else max(t_position, self._hb_t)
            return DriveReading(
                t_status,
                t_position,
                self._state,
                self._sw,
                self._position,
                self._velocity,
                self._current,
                self._nmt,
                self._hb_t,
                self._error_code,
                self._error_register,
            )

    def joint_values(self, now: float) -> JointValues:
        """The joint's values without the lock (every control step): the same values as
        :meth:`reading`, and ``usable`` is True exactly when :meth:`problem` would return
        None (when False, ask it why)."""
        t_status, t_position, state, position, velocity, current, nmt, hb_t = self._live
        p = self.params
        if self._on_change and nmt == "OPERATIONAL" and hb_t is not None:
            t_status = None if t_status is None else max(t_status, hb_t)
            t_position = None if t_position is None else max(t_position, hb_t)
        usable = (
            hb_t is not None
            and now - hb_t <= p.heartbeat_timeout
            and nmt == "OPERATIONAL"
            and state is not State.FAULT
            and state is not State.FAULT_REACTION_ACTIVE
            and t_status is not None
            and now - t_status <= p.stale_timeout
            and t_position is not None
            and now - t_position <= p.stale_timeout
            and self._fault_latched is None
        )
        return JointValues(position, velocity, current, t_position, usable)

    def fault_description(self) -> str:
        """EMCY code and error register of the current fault, decoded ('' if none known)."""
        r = self.reading()
        return describe_emcy(r.error_code or None, r.error_register)

    def refresh_fault(self) -> None:
        """Read the fault's code and register over SDO (blocking; for a fault whose EMCY we missed)."""
        code, register = read_fault(self.node, self.od)
        with self._lock:
            if code:
                self._error_code = code
            if register is not None:
                self._error_register = register

    def fault_text(self, now: float) -> str | None:
        """Why this drive is not usable right now, or None."""
        return self._fault_text(self.reading(), now)

    def _fault_text(self, r: DriveReading, now: float) -> str | None:
        """:meth:`fault_text` of reading ``r``."""
        p = self.params
        where = self.where
        if r.heartbeat_t is None:
            return f"{where}: no heartbeat received"
        if now - r.heartbeat_t > p.heartbeat_timeout:
            return f"{where}: heartbeat lost ({now - r.heartbeat_t:.2f} s, limit {p.heartbeat_timeout:.2f} s)"
        if r.state in (State.FAULT, State.FAULT_REACTION_ACTIVE):
            desc = describe_emcy(r.error_code or None, r.error_register)
            return f"{where}: CiA 402 {r.state.value}" + (f", {desc}" if desc else "")
        if r.nmt != "OPERATIONAL":  # no PDOs: the last statusword is stale; say what the drive last reported
            desc = describe_emcy(r.error_code or None, r.error_register)
            return f"{where}: NMT state {r.nmt}" + (f", last {desc}" if desc else "")
        for t, what in ((r.t_status, "statusword"), (r.t_position, "position")):
            if t is None:
                return f"{where}: no {what} PDO received"
            if now - t > p.stale_timeout:
                return f"{where}: stale {what} PDO ({now - t:.2f} s old, limit {p.stale_timeout:.2f} s)"
        return None

    def health(self, now: float) -> Health:
        r = self.reading()
        s = self.setup
        info = {
            "name": self.name,
            "node_id": self.params.node_id,
            "nmt": r.nmt,
            "cia402": r.state.value if r.state else "unknown",
            "statusword": f"0x{r.statusword:04X}",
            "heartbeat_age_s": None if r.heartbeat_t is None else round(now - r.heartbeat_t, 3),
            "transmission": s.transmission if s else None,
            "host_heartbeat_watch_s": s.host_watch_s if s else None,
        }
        if s and s.notes:
            info["notes"] = list(s.notes)
        fault = self._fault_text(r, now)
        if r.heartbeat_t is None and r.t_status is None:
            return Health(HealthState.MISSING, now, fault or "", info)
        if fault:
            return Health(HealthState.FAULT, now, fault, info)
        if self._fault_latched:
            return Health(HealthState.FAULT, now, f"{self._fault_latched} (cleared; enable to resume)", info)
        return Health(HealthState.OK, now, "", info)

    def problem(self, now: float) -> str | None:
        """Why :meth:`health` is not usable now (its ``detail``), or None: the same
        verdict without building the health report (called every control step)."""
        fault = self.fault_text(now)
        if fault:
            return fault
        if self._fault_latched:
            return f"{self._fault_latched} (cleared; enable to resume)"
        return None

    def close(self) -> None:
        self._configured = False
        try:
            self._network.unsubscribe(0x700 + self.params.node_id, self._on_heartbeat)
            self._network.unsubscribe(0x80 + self.params.node_id, self._on_emcy)
        except Exception:  # noqa: BLE001
            pass
