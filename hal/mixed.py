"""A backend with some roles on real devices and the others on the simulator.

Lets a vehicle be tried before its arm is fitted (``vehicle: {driver: ardusub}``
with ``arm: {driver: sim}``), or a real arm be exercised on a simulated
vehicle. Time is the real devices' wall clock (:class:`~hal.drivers.realtime.MonotonicClock`):
:meth:`MixedBackend.advance` sleeps to the next tick, then steps the simulator
up to the same time, so simulated readings carry times on that one clock
(at most one tick old).

The simulated roles live in the simulator's own world: a simulated arm or
detector is mounted on the *simulated* vehicle, which only moves when the
vehicle role is simulated too; a simulated detector next to a real vehicle
therefore sees the scenario's pipe from a vehicle that stays at its start pose.
``ground_truth()`` is None (the real world has none).

With ``follow_vehicle`` (HAL config ``sim: {follow_vehicle: true}``, a real
vehicle) the simulated vehicle is instead put where the real vehicle's
navigation says at every tick (``place_vehicle`` of the simulator: position,
depth and attitude, the simulator's world being the navigation's frame): a
simulated detector then sees the scenario's pipe from the real vehicle, e.g.
an autopilot in SITL searching for a simulated pipe.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hal.drivers.realtime import MonotonicClock
from hal.interfaces import Backend, DeviceSet


class _CaughtUp:
    """A simulated device whose every use first steps the simulator up to the wall
    clock, so its readings are fresh even after a blocking call (e.g. arming a real
    autopilot takes a fraction of a second during which no tick advances time)."""

    def __init__(self, device: Any, catch_up: Any) -> None:
        object.__setattr__(self, "_dev", device)
        object.__setattr__(self, "_catch_up", catch_up)

    def __getattr__(self, name: str) -> Any:
        self._catch_up()
        return getattr(self._dev, name)

    def __setattr__(self, name: str, value: Any) -> None:
        setattr(self._dev, name, value)


class MixedBackend(Backend):
    """``real``: a RealBackend holding the real roles; ``sim``: a SimBackend (not paced)."""

    realtime = True

    def __init__(self, real: Any, sim: Any, devices: DeviceSet, follow_vehicle: bool = False) -> None:
        self.real = real
        self.sim = sim
        self.follow_vehicle = follow_vehicle and any(devices.vehicle is d for d in real.devices.by_role().values())
        self.clock = real.clock
        real_devs = list(real.devices.by_role().values())
        # a _CaughtUp stands in for the simulated device it wraps (same interface, by delegation)
        wrapped: dict[str, Any] = {
            role: (dev if any(dev is r for r in real_devs) else _CaughtUp(dev, self._catch_up))
            for role, dev in devices.by_role().items()
        }
        self._sim_devices = [d for d in wrapped.values() if isinstance(d, _CaughtUp)]
        self.devices = DeviceSet.from_roles(wrapped)
        self._catch_up()  # simulated time == wall-clock time from the start

    def _catch_up(self) -> None:
        lag = self.clock.now() - self.sim.clock.now()
        if self.follow_vehicle:
            self._place()  # the simulated sensors of this step see the world from there
        if lag > 1e-6:
            self.sim.advance(lag)
            if self.follow_vehicle:
                self._place()  # and the step's own motion (the simulator's idle vehicle) is undone

    def _place(self) -> None:
        """The simulated vehicle where the real one's navigation is (while it has a pose)."""
        nav = self.devices.vehicle.navigation()
        eta = np.concatenate([np.asarray(nav.position, dtype=float)[:2], [nav.depth], nav.attitude])
        if np.all(np.isfinite(eta)):
            self.sim.place_vehicle(eta)

    def open(self) -> None:
        self.real.open()

    def open_each(self) -> dict[str, str]:
        """Connect the real devices one by one (``maris hal check``): role -> why not."""
        return self.real.open_each()

    def close(self) -> None:
        try:
            for dev in self._sim_devices:
                try:
                    dev.safe_stop()
                except Exception:  # noqa: BLE001 - closing goes on
                    pass
        finally:
            self.real.close()

    def advance(self, dt: float) -> None:
        self.real.advance(dt)
        self._catch_up()

    def prefetch_health(self) -> None:
        """The real devices' health computed between steps (``RealBackend.prefetch_health``)."""
        self.real.prefetch_health()

    @property
    def health_served(self) -> dict[str, int] | None:
        return self.real.health_served

    @property
    def overruns(self) -> int:
        return self.real.overruns

    @property
    def ticks(self) -> int:
        return self.real.ticks

    @property
    def wall_clock(self) -> MonotonicClock:
        return self.real.wall_clock

    def timing(self, since: int = 0) -> dict:
        return self.real.timing(since)
