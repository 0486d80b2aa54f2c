"""The real-device :class:`hal.interfaces.Backend`: a monotonic wall clock, the
devices built by :mod:`hal.factory`, and ``advance(dt)`` that sleeps to the next
tick. Device I/O happens in the drivers' own threads, so a tick never waits for
a device.

Life cycle: :meth:`RealBackend.open` connects every device (``connect()`` where
a device has it - the gripper's ``open()`` means "open the fingers"), and
:meth:`RealBackend.close` safe-stops and disconnects every connected device,
then the shared CAN buses, never raising; it is final (a second call does nothing).

Device health for the supervisor's tree step is computed between steps by a
worker thread (:mod:`hal.drivers.health_prefetch`) when the loop asks for it
(:meth:`RealBackend.prefetch_health`); ``health_prefetch = False`` before
:meth:`RealBackend.open` keeps every poll on the loop thread.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from hal.drivers.health_prefetch import HealthPrefetcher
from hal.drivers.realtime import STEP_GATE, MonotonicClock, TickPacer
from hal.interfaces import Backend, Device, DeviceSet, Health, HealthState

log = logging.getLogger(__name__)


class RealBackend(Backend):
    """Real devices on wall-clock time. ``resources``: extra things to close last (CAN buses)."""

    realtime = True

    def __init__(
        self, clock: MonotonicClock, devices: DeviceSet, resources: list[Callable[[], None]] | None = None
    ) -> None:
        self.clock = clock
        self._wall_clock = clock
        self.devices = devices
        self._pacer = TickPacer(clock, gate=STEP_GATE)  # the drivers' threads wait out each step
        self._resources = resources or []
        self._opened: list[Device] = []
        self._closed = False
        #: Compute the devices' health between steps when asked (:meth:`prefetch_health`);
        #: read at :meth:`open`.
        self.health_prefetch = True
        self._prefetcher: HealthPrefetcher | None = None
        self._health_counts: dict[str, int] | None = None

    def open_each(self) -> dict[str, str]:
        """Connect every device, going on after failures (for ``maris hal check``);
        returns role -> why it could not connect. Close with :meth:`close` as usual."""
        errors: dict[str, str] = {}
        for role, dev in self.devices.by_role().items():
            if isinstance(dev, UnavailableDevice):
                errors[role] = dev.reason
                continue
            try:
                dev.connect()
                self._opened.append(dev)
            except Exception as exc:  # noqa: BLE001 - each device fails its own way; reported, not raised
                errors[role] = str(exc) or type(exc).__name__
        return errors

    def open(self) -> None:
        """Connect every device; on failure, close what was opened and re-raise."""
        try:
            for dev in self.devices.by_role().values():
                dev.connect()
                self._opened.append(dev)
        except Exception:
            self.close()
            raise
        if self.health_prefetch and self._prefetcher is None:
            self._prefetcher = HealthPrefetcher(self.devices.by_role(), gate=STEP_GATE, clock=self.clock.now)
            self._prefetcher.install()  # its worker exists before the loop (--rt-priority ranks it below)

    def prefetch_health(self) -> None:
        """The next step polls the devices' health: compute it now, between the steps
        (:mod:`hal.drivers.health_prefetch`); nothing when prefetching is off."""
        if self._prefetcher is not None:
            self._prefetcher.request()

    def close(self) -> None:
        """Safe-stop and disconnect the connected devices, then release the buses.
        Final and idempotent: later calls do nothing (the buses are gone)."""
        if self._closed:
            return
        self._closed = True
        STEP_GATE.open()  # no step runs any more: the drivers' threads must not wait for one
        if self._prefetcher is not None:
            self._prefetcher.close()  # the devices' own health() back, before they stop
            self._health_counts = self.health_served
            self._prefetcher = None
        for dev in self._opened:  # a device never connected has nothing to stop
            try:
                dev.safe_stop()
            except Exception:  # noqa: BLE001 - closing must go on for the others
                log.exception("safe stop of %s failed", dev.name)
        for dev in reversed(self._opened):
            try:
                dev.disconnect()
            except Exception:  # noqa: BLE001
                log.exception("closing %s failed", dev.name)
        self._opened.clear()
        for release in self._resources:
            try:
                release()
            except Exception:  # noqa: BLE001
                log.exception("releasing a bus failed")
        self._resources.clear()

    def advance(self, dt: float) -> None:
        """Sleep until ``dt`` s after the previous tick."""
        pf = self._prefetcher
        if pf is not None:
            last = self._pacer.last_tick
            pf.step_ends((self.clock.now() if last is None else last) + dt)  # the tick the pacer sleeps for
        self._pacer.advance(dt)
        if pf is not None:
            pf.step_begins()

    @property
    def health_served(self) -> dict[str, int] | None:
        """Device health calls served from the prefetch worker (``prefetched``), computed on
        the loop thread while a prefetch was open (``on_loop``), and the prefetches the
        worker cut short near the tick (``left_to_step``); None when prefetching was off.
        Kept after :meth:`close`."""
        pf = self._prefetcher
        if pf is None:
            return self._health_counts
        return {"prefetched": pf.served, "on_loop": pf.computed_by_caller, "left_to_step": pf.left_to_step}

    @property
    def overruns(self) -> int:
        """Ticks that started more than one period late."""
        return self._pacer.overruns

    @property
    def ticks(self) -> int:
        """Ticks so far (calls of :meth:`advance`)."""
        return self._pacer.ticks

    @property
    def wall_clock(self) -> MonotonicClock:
        """The backend clock itself, for wall-clock measurements that must not go through a
        wrapper of :attr:`clock` (the input record of ``maris log replay`` records every read)."""
        return self._wall_clock

    def timing(self, since: int = 0) -> dict:
        """Tick figures from tick ``since`` on: missed ticks, lateness (:meth:`TickPacer.timing`)."""
        return self._pacer.timing(since)


class UnavailableDevice(Device):
    """Stands in for a device that could not even be built (``build_backend(failed=...)``):
    always FAULT with the reason."""

    def __init__(self, role: str, reason: str, clock: Callable[[], float]) -> None:
        self.name = role
        self.reason = reason
        self._clock = clock
        self.joint_names: tuple[str, ...] = ()

    def health(self) -> Health:
        return Health(HealthState.FAULT, self._clock(), f"cannot be set up: {self.reason}")
