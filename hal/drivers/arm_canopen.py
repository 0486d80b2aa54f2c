"""The arm as a set of CiA 402 joint drives on one CANopen bus (MARIS: Faulhaber
motion controllers, one per joint, profile velocity mode).

Implements :class:`hal.interfaces.Arm`. A fault of any joint (drive FAULT,
lost heartbeat, stale PDO, NMT not operational) brings *all* joints to the safe
state (quick stop, then switch-on-disabled) and is reported by :meth:`health`
and in ``JointState.fault`` until :meth:`enable` is called again, which also
resets drive faults.
"""

from __future__ import annotations

import threading
import time
from typing import Callable

import numpy as np

from hal.drivers.canbus import CanopenBus
from hal.drivers.canopen_drive import Cia402Drive, DriveParams
from hal.drivers.cia402 import State
from hal.interfaces import Arm, Health, HealthState, JointState

#: Longest time (s) close() waits for the drives to reach switch-on-disabled.
CLOSE_TIMEOUT = 1.5


def drive_params(joint: dict, common: dict, host_node_id: int = 127) -> DriveParams:
    """DriveParams from one joint/motor entry of a validated HAL config plus the device-wide settings."""
    return DriveParams(
        host_node_id=host_node_id,
        host_heartbeat_timeout=common.get("host_heartbeat_timeout", 0.5),
        node_id=joint["node_id"],
        counts_per_rad=joint["counts_per_rad"],
        velocity_units_per_rad_s=joint["velocity_units_per_rad_s"],
        max_velocity=joint["max_velocity"],
        heartbeat_period=common["heartbeat_period"],
        heartbeat_timeout=common["heartbeat_timeout"],
        pdo_period=common["pdo_period"],
        stale_timeout=common["stale_timeout"],
    )


def wait_for_states(drives: list[Cia402Drive], wanted: State, timeout: float) -> bool:
    """Poll (bounded) until every drive reports ``wanted``; True if they all did."""
    live = [d for d in drives if d.reading().state is not None]  # a drive never heard from cannot answer
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if all(d.reading().state == wanted for d in live):
            return True
        time.sleep(0.01)
    return False


class CanopenArm(Arm):
    """Arm joints on CiA 402 drives. ``params`` is the validated ``canopen_arm`` config."""

    name = "arm"

    def __init__(self, bus: CanopenBus, params: dict, clock: Callable[[], float]) -> None:
        self._bus = bus
        self._clock = clock
        self.joint_names = tuple(j["name"] for j in params["joints"])
        self.drives = [Cia402Drive(bus.network, params["eds"], drive_params(j, params, bus.host_node_id), clock, j["name"]) for j in params["joints"]]
        self._opened = False
        self._lock = threading.Lock()  # enable/disable vs. the bus thread's all-or-none check

    def connect(self) -> None:
        """Set up (SDO) and start every joint drive; they stay disabled until enable().
        On a DriveError the drives already started are taken down again."""
        self._opened = True
        self._bus.register(self)
        try:
            for d in self.drives:
                d.configure()
                self._bus.register(d)
        except Exception:
            self.disconnect()
            raise

    def service(self, now: float) -> None:
        """Bus thread: one joint out of service takes every joint to the safe state."""
        with self._lock:
            enabled = [d.target_state == State.OPERATION_ENABLED for d in self.drives]
            if any(enabled) and not all(enabled):
                for d in self.drives:
                    d.request_safe_state()

    def disconnect(self) -> None:
        """Quick stop, switch-on-disabled, release. Idempotent."""
        if not self._opened:
            return
        self.disable()
        wait_for_states(self.drives, State.SWITCH_ON_DISABLED, CLOSE_TIMEOUT)
        self._bus.unregister(self)
        for d in self.drives:
            self._bus.unregister(d)
            d.close()
        self._opened = False

    def enable(self) -> None:
        with self._lock:
            for d in self.drives:
                d.set_velocity(0.0)
                d.request_enable()

    def disable(self) -> None:
        with self._lock:
            for d in self.drives:
                d.request_safe_state()

    def safe_stop(self) -> None:
        try:
            self.disable()
        except Exception:  # noqa: BLE001 - must not raise
            pass

    def command_joint_velocity(self, qdot: np.ndarray) -> None:
        qdot = np.asarray(qdot, dtype=float).reshape(-1)
        if qdot.shape != (len(self.drives),):
            raise ValueError(f"arm: expected {len(self.drives)} joint velocities, got shape {qdot.shape}")
        if not np.all(np.isfinite(qdot)):
            self.safe_stop()
            return
        if any(d.target_state != State.OPERATION_ENABLED for d in self.drives):
            return  # disabled or faulted: references are ignored until enable()
        for d, v in zip(self.drives, qdot):
            d.set_velocity(v)

    def joint_state(self) -> JointState:
        now = self._clock()
        readings = [d.reading() for d in self.drives]
        faults = [f for f in (d.health(now) for d in self.drives) if not f.state.usable]
        times = [r.t_position for r in readings if r.t_position is not None]
        return JointState(
            t=min(times) if len(times) == len(readings) and times else float("nan"),
            position=np.array([r.position for r in readings]),
            velocity=np.array([r.velocity for r in readings]),
            current=np.array([r.current for r in readings]),
            fault="; ".join(f.detail for f in faults) or None,
        )

    def health(self) -> Health:
        now = self._clock()
        return combine_health([d.health(now) for d in self.drives], now)


def combine_health(parts: list[Health], now: float) -> Health:
    """Worst of the drives' health; detail lists every problem; info per drive."""
    order = [HealthState.OK, HealthState.DEGRADED, HealthState.FAULT, HealthState.MISSING]
    worst = max((h.state for h in parts), key=order.index, default=HealthState.MISSING)
    detail = "; ".join(h.detail for h in parts if h.detail)
    info = {"drives": [h.info for h in parts]}
    return Health(worst, now, detail, info)
