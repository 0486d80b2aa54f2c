"""The safety monitors' input, read from the devices once per base step.

Navigation and joint readings are fresh every step (the caller passes them);
device health and the slower streams (gripper, wrench, detector) are polled
only when asked (the tree rate in the loop: health queries can be slow on real
drivers) and reused in between. Times are backend clock seconds.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from hal.interfaces import DeviceSet, HealthState
from mission.runtime.recorder import RunRecorder
from mission.runtime.safety import PolledDevices, SafetyMonitor, classify_health
from mission.spec import WATCHDOG_ROLES


class DevicePoller:
    def __init__(
        self, clock: Any, devices: DeviceSet, monitor: SafetyMonitor, rec: RunRecorder, t0: float = 0.0
    ) -> None:
        self.clock = clock
        self.devices = devices
        self.monitor = monitor
        self.rec = rec
        self.t0 = t0
        #: What the last poll found (nothing before the first, which :meth:`read` always makes).
        self.polled = PolledDevices()
        self._never_polled = True

    def read(self, poll_devices: bool = True) -> float:
        """The clock (s) for this step's checks; health and the slow streams polled when
        ``poll_devices`` (or never yet), else kept from the last poll (:attr:`polled`)."""
        now = self.clock.now()
        if poll_devices or self._never_polled:
            health = {role: dev.health() for role, dev in self.devices.by_role().items()}
            others: dict[str, float | None] = {}
            gripper_fault = None
            watched = self.monitor.watchdog_s
            if self.devices.gripper is not None and "gripper" in watched:
                gs = self.devices.gripper.state()
                others["gripper"] = gs.t
                gripper_fault = gs.fault
            if self.devices.wrench_sensor is not None and "wrench" in watched:
                w = self.devices.wrench_sensor.wrench()
                others["wrench"] = None if w is None else w.t
            if "detector" in watched and self.devices.detector is not None:
                h = health.get("detector")
                others["detector"] = now if h is not None and h.state.usable else None
            # a degraded device (e.g. DVL without bottom lock) is usable; only FAULT/MISSING count
            bad = {r: h for r, h in health.items() if h.state in (HealthState.FAULT, HealthState.MISSING)}
            self.rec.health(now, health)
            self.polled = PolledDevices(bad, others, gripper_fault)
            self._never_polled = False
        return now

    def preflight_problems(self) -> list[str]:
        """Why the run may not start now (empty: ready): missing watched devices,
        unusable devices, non-finite navigation or joints, envelope/watchdog breaches.
        A lost sensor whose fault-table ending is ``warn`` (e.g. the DVL without
        bottom lock) does not block the start, on real and simulated devices alike."""
        problems = []
        present = self.devices.by_role()
        for stream in self.monitor.watchdog_s:
            role = WATCHDOG_ROLES.get(stream)
            if role is not None and role not in present:
                problems.append(f"the mission watches `{stream}` but there is no {role} device")
        for role, dev in present.items():
            h = dev.health()
            if not h.state.usable and any(b.ending != "warn" for b in classify_health(role, h)):
                problems.append(f"{role} {h.state.value}: {h.detail}")
        nav = self.devices.vehicle.navigation()
        if not (np.all(np.isfinite(nav.position)) and np.all(np.isfinite(nav.attitude)) and math.isfinite(nav.depth)):
            problems.append("navigation not valid (non-finite pose)")
        js = self.devices.arm.joint_state()
        if not np.all(np.isfinite(js.position)):
            problems.append("arm joint positions not valid")
        now = self.read()
        breaches, _ = self.monitor.check(now, now - self.t0, nav, js, self.polled)
        device_kinds = (
            "drive_fault",
            "gripper_fault",
            "vehicle_link",
            "sensor_lost",
            "operator_input",
        )  # from health above
        problems += [
            str(b) for b in breaches if b.source != "duration_s" and b.ending != "warn" and b.kind not in device_kinds
        ]
        return problems


class AltitudeFloorWatch:
    """Says (events marked for the run summary) when the altitude floor
    ``min_altitude_m`` cannot be enforced: without an altitude measurement (no
    DVL, or no bottom lock) the envelope has nothing to compare it with."""

    def __init__(self, floor_m: float, events: Any) -> None:
        self.floor_m = float(floor_m or 0.0)
        self.events = events
        #: Run time (s) without an altitude measurement.
        self.unknown_s = 0.0
        self._known_at_start = True

    def unknown_for(self, dt: float) -> None:
        self.unknown_s += dt

    def start(self, nav: Any) -> None:
        """At the end of a successful preflight."""
        if self.floor_m > 0.0 and nav.altitude is None:
            self._known_at_start = False
            self.events.emit(
                "altitude_floor",
                f"no altitude measurement (no DVL, or no bottom lock): the altitude floor "
                f"min_altitude_m {self.floor_m:g} m is NOT enforced while it lasts",
                level="warning",
                summary=True,
            )

    def end(self) -> None:
        """At the end of the run: how long the floor went unenforced (if it was at the start)."""
        if self.floor_m > 0.0 and self._known_at_start and self.unknown_s > 0.0:
            self.events.emit(
                "altitude_floor",
                f"no altitude measurement for {self.unknown_s:.1f} s of the run: the "
                f"altitude floor min_altitude_m {self.floor_m:g} m was not enforced then",
                level="warning",
                summary=True,
            )
