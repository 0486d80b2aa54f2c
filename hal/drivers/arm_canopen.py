"""The arm as a set of CiA 402 joint drives on one CANopen bus (MARIS: Faulhaber
motion controllers, one per joint, profile velocity mode).

Implements :class:`hal.interfaces.Arm`. A fault of any joint (drive FAULT,
lost heartbeat, stale PDO, NMT not operational) brings *all* joints to the safe
state (quick stop, then switch-on-disabled) and is reported by :meth:`health`
and in ``JointState.fault`` until :meth:`enable` is called again, which also
resets drive faults; :meth:`CanopenArm.reset_faults` resets them without
enabling (the documented preflight reset, ``maris run --reset-faults``).

Closing (:meth:`CanopenArm.disconnect`) disables every joint, then releases
each drive (it stops watching our heartbeat and goes PRE-OPERATIONAL), so the
next session finds the drives without a fault.
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
from collections.abc import Callable, Iterator

import numpy as np

from hal.config import site_of
from hal.drivers.canbus import CanopenBus, Serviced
from hal.drivers.canopen_drive import FAULT_RESET_TIMEOUT, Cia402Drive, DriveParams, EdsError
from hal.drivers.cia402 import State
from hal.drivers.setup_checks import SetupError
from hal.interfaces import Arm, Health, HealthState, JointState

#: Longest time (s) close() waits for the drives to reach switch-on-disabled.
CLOSE_TIMEOUT = 1.5


def drive_params(joint: dict, common: dict, host_node_id: int = 127, sync_period: float | None = None) -> DriveParams:
    """DriveParams from one joint/motor entry of a validated HAL config plus the device-wide
    settings; ``host_node_id`` and ``sync_period`` (s) come from the bus."""
    return DriveParams(
        host_node_id=host_node_id,
        host_heartbeat_timeout=common.get("host_heartbeat_timeout", 0.5),
        transmission=common.get("transmission") or "auto",
        sync_period=sync_period,
        rated_current_a=joint.get("rated_current_a", common.get("rated_current_a")),
        node_id=joint["node_id"],
        counts_per_rad=joint["counts_per_rad"],
        velocity_units_per_rad_s=joint["velocity_units_per_rad_s"],
        max_velocity=joint["max_velocity"],
        heartbeat_period=common["heartbeat_period"],
        heartbeat_timeout=common["heartbeat_timeout"],
        pdo_period=common["pdo_period"],
        stale_timeout=common["stale_timeout"],
    )


class EdsSetupError(SetupError, EdsError):
    """An unusable EDS found while the devices are built: both a set-up error (the start is
    refused) and an :class:`EdsError`; the message names the config's ``eds`` field first."""


@contextlib.contextmanager
def eds_errors_named(params: dict) -> Iterator[None]:
    """An unusable EDS (:class:`EdsError`) as an :class:`EdsSetupError` naming the config field."""
    try:
        yield
    except EdsError as exc:
        raise EdsSetupError(f"{site_of(params, 'eds')}: {exc}") from None


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
        with eds_errors_named(params):
            self.drives = [
                Cia402Drive(
                    bus.network,
                    params["eds"],
                    drive_params(j, params, bus.host_node_id, bus.sync_period),
                    clock,
                    j["name"],
                    where=f"arm joint {j['name']}",
                )
                for j in params["joints"]
            ]
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
        """Quick stop, switch-on-disabled, release (see the module docstring). Idempotent."""
        if not self._opened:
            return
        self.disable()
        wait_for_states(self.drives, State.SWITCH_ON_DISABLED, CLOSE_TIMEOUT)
        release_drives(self._bus, self, self.drives)
        self._opened = False

    def reset_faults(self) -> list[str]:
        """Reset the faulted joints' drives, leaving every joint disabled; blocks up to
        ~1 s. Returns one line per drive that was faulted: its fault, decoded."""
        return reset_drive_faults(self.drives, self._clock, self._lock)

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
        values = qdot.tolist()  # plain floats: every control step, cheaper than numpy on seven values
        if not all(map(math.isfinite, values)):
            self.safe_stop()
            return
        enabled = State.OPERATION_ENABLED
        for d in self.drives:
            if d.target_state is not enabled:
                return  # disabled or faulted: references are ignored until enable()
        for d, v in zip(self.drives, values):
            d.set_velocity(v)

    def joint_state(self) -> JointState:
        """Every joint's latest reading (without the drives' locks: every control step);
        ``fault`` joins the problems of the joints not usable now (:meth:`Cia402Drive.problem`)."""
        now = self._clock()
        pos, vel, cur = [], [], []
        t_min: float | None = float("inf")
        faults = []
        for d in self.drives:
            p, v, c, t, usable = d.joint_values(now)
            pos.append(p)
            vel.append(v)
            cur.append(c)
            if t is None:
                t_min = None
            elif t_min is not None and t < t_min:
                t_min = t
            if not usable:
                problem = d.problem(now)
                if problem:
                    faults.append(problem)
        return JointState(
            t=float("nan") if t_min is None or not self.drives else t_min,
            position=np.array(pos, dtype=float),
            velocity=np.array(vel, dtype=float),
            current=np.array(cur, dtype=float),
            fault="; ".join(faults) or None,
        )

    def health(self) -> Health:
        now = self._clock()
        return combine_health([d.health(now) for d in self.drives], now)


def release_drives(bus: CanopenBus, owner: Serviced, drives: list[Cia402Drive]) -> None:
    """Stop servicing, then release every drive (clean close) and drop its subscriptions."""
    bus.unregister(owner)
    for d in drives:
        bus.unregister(d)
    for d in drives:
        try:
            d.release()
        finally:
            d.close()


def reset_drive_faults(drives: list[Cia402Drive], clock: Callable[[], float], lock: threading.Lock) -> list[str]:
    """Fault reset (to SWITCH ON DISABLED) of every faulted drive; what each fault was."""
    faulted = [
        d
        for d in drives
        if d.reading().state in (State.FAULT, State.FAULT_REACTION_ACTIVE)
        or d.health(clock()).state == HealthState.FAULT
    ]
    reports = []
    for d in faulted:
        if d.reading().state == State.FAULT and not d.reading().error_code:
            d.refresh_fault()  # its EMCY went out before we listened (e.g. during the previous session's end)
        reports.append(d.fault_text(clock()) or f"{d.where}: fault latched: {d.health(clock()).detail}")
    with lock:
        for d in faulted:
            d.set_velocity(0.0)
            d.request_fault_reset()
    deadline = time.monotonic() + 2 * FAULT_RESET_TIMEOUT
    while time.monotonic() < deadline and any(
        d.reading().state in (State.FAULT, State.FAULT_REACTION_ACTIVE) for d in faulted
    ):
        time.sleep(0.01)
    return reports


def combine_health(parts: list[Health], now: float) -> Health:
    """Worst of the drives' health; detail lists every problem; ``info["parts"]`` one entry
    per drive (its name, state, detail and diagnostics) for ``maris hal check``."""
    order = [HealthState.OK, HealthState.DEGRADED, HealthState.FAULT, HealthState.MISSING]
    worst = max((h.state for h in parts), key=order.index, default=HealthState.MISSING)
    detail = "; ".join(h.detail for h in parts if h.detail)
    info = {
        "parts": [
            {
                "name": h.info.get("name", "?"),
                "state": h.state.value,
                "detail": h.detail,
                **{k: v for k, v in h.info.items() if k != "name"},
            }
            for h in parts
        ]
    }
    return Health(worst, now, detail, info)
