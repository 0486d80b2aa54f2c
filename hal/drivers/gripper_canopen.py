"""A multi-finger gripper whose motor groups are CiA 402 drives on the shared
CANopen bus (MARIS: distal, proximal and palm groups, Faulhaber motors).

Implements :class:`hal.interfaces.Gripper`. Motions run in the bus thread
(:meth:`CanopenGripper.service`) as small velocity loops:

* preshape: the ``palm`` group moves to the preshape's position (rad), fingers open;
* close: every finger group (all groups but ``palm``) closes at
  ``close_velocity`` until its current reaches the limit (stalled on the object:
  HOLDING) or it stops moving (end of travel);
* open: finger groups go back to ``open_position``.

Any drive fault stops every group (safe state) and shows in ``health()`` and
``GripperState.fault``; motion commands are then refused (RuntimeError) until
:meth:`CanopenGripper.reset_fault` is called. Closing on a current limit needs
motor currents: :meth:`CanopenGripper.connect` refuses finger drives without a
current reading (0x6078) or a rated current (0x6075 or ``rated_current_a``).

Life cycle: :class:`hal.interfaces.Gripper` uses ``open()``/``close(limit)`` for
the fingers, so the bus connection is made by :meth:`CanopenGripper.connect`
and released by :meth:`CanopenGripper.disconnect` (the real backend calls
those for every device that has them).
"""

from __future__ import annotations

import threading
from collections.abc import Callable

import numpy as np

from hal.drivers.arm_canopen import (
    CLOSE_TIMEOUT,
    combine_health,
    drive_params,
    eds_errors_named,
    release_drives,
    reset_drive_faults,
    wait_for_states,
)
from hal.drivers.canbus import CanopenBus
from hal.drivers.canopen_drive import Cia402Drive, DriveError
from hal.drivers.cia402 import State
from hal.interfaces import Gripper, GripperMotion, GripperState, Health

PALM = "palm"
POSITION_TOLERANCE = 0.02  # rad
POSITION_GAIN = 4.0  # 1/s, palm and opening loops
STALL_SPEED = 0.01  # rad/s: a closing finger slower than this for STALL_TIME has stopped
STALL_TIME = 0.3  # s


class CanopenGripper(Gripper):
    """Gripper motor groups on CiA 402 drives. ``params`` is the validated ``canopen_gripper`` config."""

    name = "gripper"

    def __init__(self, bus: CanopenBus, params: dict, clock: Callable[[], float]) -> None:
        self._bus = bus
        self._clock = clock
        self.groups = tuple(params["motors"])
        self.preshapes = tuple(params["preshapes"])
        self._preshape_pos = {k: float(v) for k, v in params["preshapes"].items()}
        self._close_velocity = params["close_velocity"]
        self._open_position = params["open_position"]
        with eds_errors_named(params):
            self.drives = {
                g: Cia402Drive(
                    bus.network,
                    params["eds"],
                    drive_params(m, params, bus.host_node_id, bus.sync_period),
                    clock,
                    f"gripper.{g}",
                    where=f"gripper motor {g}",
                )
                for g, m in params["motors"].items()
            }
        self._lock = threading.Lock()
        self._motion = GripperMotion.IDLE
        self._goal: float | None = None
        self._current_limit = 0.0
        self._finger_done: dict[str, bool] = {}
        self._slow_since: dict[str, float | None] = {}
        self._opened = False

    # ------------------------------------------------------------------ life cycle

    def connect(self) -> None:
        """Set up the drives (SDO) and start them, still disabled (blocking, once)."""
        self._opened = True  # drives stay disabled until the first motion command
        self._bus.register(self)
        try:
            for g, d in self.drives.items():
                d.configure()
                self._bus.register(d)
                if g != PALM and (d.setup is None or d.setup.rated_current_a is None or 0x6078 not in d.od.od):
                    why = "no current actual value 0x6078" if 0x6078 not in d.od.od else "no rated current 0x6075"
                    raise DriveError(
                        f"{d.where}: closing on a current limit needs motor currents, but EDS {d.od.path} has "
                        f"{why}" + ("; set `rated_current_a` in the HAL config" if 0x6078 in d.od.od else "")
                    )
        except Exception:
            self.disconnect()
            raise

    def disconnect(self) -> None:
        """Stop, bring every drive to switch-on-disabled, release (see
        :mod:`hal.drivers.arm_canopen`). Idempotent."""
        if not self._opened:
            return
        self.stop()
        for d in self.drives.values():
            d.request_safe_state()
        wait_for_states(list(self.drives.values()), State.SWITCH_ON_DISABLED, CLOSE_TIMEOUT)
        release_drives(self._bus, self, list(self.drives.values()))
        self._opened = False

    def reset_faults(self) -> list[str]:
        """Reset faulted motor drives without moving anything (motion IDLE); what each fault was."""
        reports = reset_drive_faults(list(self.drives.values()), self._clock, self._lock)
        with self._lock:
            self._motion = GripperMotion.IDLE
        return reports

    # ------------------------------------------------------------------ commands

    def reset_fault(self) -> None:
        """Explicitly reset drive faults and re-enable every motor group (motion IDLE)."""
        with self._lock:
            for d in self.drives.values():
                d.set_velocity(0.0)
                d.request_enable(reset_fault=True)
            self._motion = GripperMotion.IDLE

    def _start(self, motion: GripperMotion, goal: float | None = None) -> None:
        now = self._clock()
        bad = [h.detail for h in (d.health(now) for d in self.drives.values()) if not h.state.usable]
        if bad:  # a fault is never reset by a motion command: see reset_fault()
            raise RuntimeError(f"gripper not usable: {'; '.join(bad)}")
        with self._lock:
            for d in self.drives.values():
                d.set_velocity(0.0)
                if d.target_state != State.OPERATION_ENABLED:
                    d.request_enable()
            self._motion = motion
            self._goal = goal
            self._finger_done = {g: False for g in self.drives if g != PALM}
            self._slow_since = {g: None for g in self.drives}

    def preshape(self, shape: str) -> None:
        if shape not in self._preshape_pos:
            raise ValueError(f"gripper: unknown preshape `{shape}`; known: {', '.join(self.preshapes)}")
        self._start(GripperMotion.PRESHAPING, self._preshape_pos[shape])

    def close(self, current_limit: float) -> None:
        if not (current_limit > 0):
            raise ValueError(f"gripper: current limit must be > 0 A, got {current_limit}")
        self._start(GripperMotion.CLOSING)
        with self._lock:
            self._current_limit = float(current_limit)

    def open(self) -> None:
        self._start(GripperMotion.OPENING, self._open_position)

    def stop(self) -> None:
        with self._lock:
            for d in self.drives.values():
                d.set_velocity(0.0)
            if self._motion not in (GripperMotion.HOLDING, GripperMotion.IDLE):
                self._motion = GripperMotion.STOPPED

    def safe_stop(self) -> None:
        try:
            self.stop()
        except Exception:  # noqa: BLE001 - must not raise
            pass

    # ------------------------------------------------------------------ bus thread

    def service(self, now: float) -> None:
        with self._lock:
            if any(not d.health(now).state.usable and not d.resetting(now) for d in self.drives.values()):
                if self._motion not in (GripperMotion.IDLE, GripperMotion.STOPPED):
                    self._motion = GripperMotion.STOPPED
                for d in self.drives.values():
                    d.request_safe_state()
                return
            m = self._motion
            if m == GripperMotion.PRESHAPING and PALM in self.drives:
                if self._track(self.drives[PALM], self._goal or 0.0):
                    self._motion = GripperMotion.IDLE
            elif m == GripperMotion.PRESHAPING:
                self._motion = GripperMotion.IDLE
            elif m == GripperMotion.OPENING:
                done = [self._track(d, self._open_position) for g, d in self.drives.items() if g != PALM]
                if all(done):
                    self._motion = GripperMotion.IDLE
            elif m == GripperMotion.CLOSING:
                self._close_step(now)

    def _track(self, d: Cia402Drive, goal: float) -> bool:
        err = goal - d.reading().position
        if abs(err) < POSITION_TOLERANCE:
            d.set_velocity(0.0)
            return True
        v = float(np.clip(POSITION_GAIN * err, -self._close_velocity, self._close_velocity))
        d.set_velocity(v)
        return False

    def _close_step(self, now: float) -> None:
        for g, d in self.drives.items():
            if g == PALM or self._finger_done[g]:
                continue
            r = d.reading()
            if abs(r.current) >= self._current_limit:
                d.set_velocity(0.0)
                self._finger_done[g] = True
                continue
            d.set_velocity(self._close_velocity)
            if abs(r.velocity) < STALL_SPEED:
                since = self._slow_since[g]
                if since is None:
                    since = self._slow_since[g] = now
                if now - since > STALL_TIME:
                    d.set_velocity(0.0)
                    self._finger_done[g] = True
            else:
                self._slow_since[g] = None
        if all(self._finger_done.values()):
            fingers = [d for g, d in self.drives.items() if g != PALM]
            stalled_on_object = any(abs(d.reading().current) >= self._current_limit for d in fingers)
            self._motion = GripperMotion.HOLDING if stalled_on_object else GripperMotion.IDLE

    # ------------------------------------------------------------------ readings

    def state(self) -> GripperState:
        now = self._clock()
        values = [d.joint_values(now) for d in self.drives.values()]  # without the drives' locks
        # a drive not usable now: its problem is what its health() would say (the detail)
        bad = [p for v, d in zip(values, self.drives.values()) if not v.usable and (p := d.problem(now))]
        times = [v.t_position for v in values if v.t_position is not None]
        with self._lock:
            motion = self._motion
        return GripperState(
            t=min(times) if len(times) == len(values) and times else float("nan"),
            positions=np.array([v.position for v in values], dtype=float),
            currents=np.array([v.current for v in values], dtype=float),
            motion=motion,
            fault="; ".join(bad) or None,
        )

    def health(self) -> Health:
        now = self._clock()
        return combine_health([d.health(now) for d in self.drives.values()], now)
