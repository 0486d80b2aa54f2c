"""Device health computed between steps (hal.drivers.health_prefetch): which thread computes
it, which step it serves, errors, and never two computations of one device at once."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

import pytest

from hal.drivers.health_prefetch import HealthPrefetcher
from hal.drivers.realtime import StepGate
from hal.interfaces import Health, HealthState


class CountingDevice:
    """A device whose health says which call it is and on which thread it was computed."""

    def __init__(self, name: str, delay_s: float = 0.0) -> None:
        self.name = name
        self.delay_s = delay_s
        self.calls: list[str] = []
        self.fail: Exception | None = None
        self.active = 0
        self.max_active = 0
        self._lock = threading.Lock()

    def health(self) -> Health:
        with self._lock:
            self.active += 1
            self.max_active = max(self.max_active, self.active)
        try:
            if self.delay_s:
                time.sleep(self.delay_s)
            self.calls.append(threading.current_thread().name)
            if self.fail is not None:
                raise self.fail
            return Health(HealthState.OK, float(len(self.calls)), f"{self.name} call {len(self.calls)}")
        finally:
            with self._lock:
                self.active -= 1


def wait_for(cond, timeout: float = 10.0) -> None:  # noqa: ANN001
    end = time.monotonic() + timeout
    while not cond():
        assert time.monotonic() < end, "timed out"
        time.sleep(0.001)


@contextmanager
def prefetching(devices: dict, **kwargs) -> Iterator[HealthPrefetcher]:
    """An installed prefetcher for ``devices``, closed afterwards."""
    pf = HealthPrefetcher(devices, **kwargs)
    pf.install()
    try:
        yield pf
    finally:
        pf.close()


@pytest.fixture()
def devices():
    devs = {"vehicle": CountingDevice("vehicle"), "arm": CountingDevice("arm")}
    yield devs


def test_the_step_after_a_request_reads_what_the_worker_computed(devices) -> None:  # noqa: ANN001
    with prefetching(devices) as pf:
        assert devices["arm"].health().detail == "arm call 1"  # no request: computed by the caller
        assert devices["arm"].calls == ["MainThread"]
        pf.request()  # end of the step before the tree step
        pf.step_ends()  # the loop hands over to the pacer: the worker starts
        wait_for(lambda: all(len(d.calls) == (2 if r == "arm" else 1) for r, d in devices.items()))
        pf.step_begins()  # the tree step
        h = devices["arm"].health()
        assert h.detail == "arm call 2" and devices["arm"].calls[-1] == "health-prefetch"
        assert devices["vehicle"].health().detail == "vehicle call 1"
        assert pf.served == 2 and pf.computed_by_caller == 0
        # a second call in the same step is computed then (fresh), not served again
        assert devices["arm"].health().detail == "arm call 3" and devices["arm"].calls[-1] == "MainThread"
        pf.step_begins()  # the next step: the prefetched values are gone
        assert devices["vehicle"].health().detail == "vehicle call 2"
        assert devices["vehicle"].calls[-1] == "MainThread"


def test_results_never_serve_a_later_step_or_a_step_without_a_request(devices) -> None:  # noqa: ANN001
    with prefetching(devices) as pf:
        pf.request()
        pf.step_ends()
        wait_for(lambda: all(len(d.calls) == 1 for d in devices.values()))
        pf.step_begins()  # the tree step reads nothing (e.g. the run ended)
        pf.step_begins()
        assert devices["arm"].health().detail == "arm call 2"  # computed now, not the old one


def test_a_health_error_is_raised_by_the_call_that_reads_it(devices) -> None:  # noqa: ANN001
    with prefetching(devices) as pf:
        devices["arm"].fail = RuntimeError("bus gone")
        pf.request()
        pf.step_ends()
        wait_for(lambda: len(devices["arm"].calls) == 1 and len(devices["vehicle"].calls) == 1)
        pf.step_begins()
        with pytest.raises(RuntimeError, match="bus gone"):
            devices["arm"].health()
        assert devices["vehicle"].health().state is HealthState.OK


@pytest.mark.slow
def test_a_device_being_computed_is_waited_for_and_never_computed_twice_at_once() -> None:
    slow = {"vehicle": CountingDevice("vehicle", delay_s=0.3), "arm": CountingDevice("arm")}
    with prefetching(slow) as pf:
        pf.request()
        pf.step_ends()
        wait_for(lambda: slow["vehicle"].active == 1)  # the worker is inside the vehicle's health
        pf.step_begins()  # the step starts before the worker is done (a slow host)
        h = slow["arm"].health()  # not started by the worker: the loop computes it, the worker skips it
        assert slow["arm"].calls == ["MainThread"] and h.detail == "arm call 1"
        h = slow["vehicle"].health()  # waits for the worker's computation, and gets it
        assert h.detail == "vehicle call 1" and slow["vehicle"].calls == ["health-prefetch"]
        time.sleep(0.1)
        assert slow["arm"].calls == ["MainThread"]  # the worker did not compute it again
        assert slow["vehicle"].max_active == 1 and pf.served == 1 and pf.computed_by_caller == 1


def test_the_worker_waits_while_a_step_runs() -> None:
    gate = StepGate(max_hold=60.0)
    devs = {"vehicle": CountingDevice("vehicle")}
    with prefetching(devs, gate=gate) as pf:
        try:
            gate.close()  # a step runs
            pf.request()
            pf.step_ends()
            time.sleep(0.2)
            assert devs["vehicle"].calls == []  # held at the gate
            gate.open()  # the step is done
            wait_for(lambda: devs["vehicle"].calls == ["health-prefetch"])
        finally:
            gate.open()


def test_close_gives_the_devices_their_own_health_back(devices) -> None:  # noqa: ANN001
    pf = HealthPrefetcher(devices)
    pf.install()
    assert "health" in vars(devices["arm"])
    pf.close()
    pf.close()  # idempotent
    assert "health" not in vars(devices["arm"])
    assert devices["arm"].health().detail == "arm call 1"


def test_near_the_tick_the_worker_leaves_the_devices_to_the_step(devices) -> None:  # noqa: ANN001
    now = {"t": 10.0}
    with prefetching(devices, clock=lambda: now["t"], margin_s=0.002) as pf:
        pf.request()
        pf.step_ends(next_tick=10.0005)  # the host stalled: the tick is 0.5 ms away when the worker gets to run
        wait_for(lambda: pf.left_to_step == 1)
        assert all(d.calls == [] for d in devices.values())  # started none
        pf.step_begins()
        assert devices["arm"].health().detail == "arm call 1" and devices["arm"].calls == ["MainThread"]
        assert pf.computed_by_caller == 1 and pf.served == 0
        pf.step_ends()
        pf.request()
        pf.step_ends(next_tick=10.008)  # a normal step: 8 ms to go
        wait_for(lambda: all(d.calls[-1:] == ["health-prefetch"] for d in devices.values()))
        pf.step_begins()
        assert devices["vehicle"].health().detail == "vehicle call 1" and pf.served == 1


def test_the_worker_stops_once_the_step_it_prefetched_for_is_over() -> None:
    slow = {"vehicle": CountingDevice("vehicle", delay_s=0.2), "arm": CountingDevice("arm")}
    with prefetching(slow) as pf:
        pf.request()
        pf.step_ends()
        wait_for(lambda: slow["vehicle"].active == 1)
        pf.step_begins()
        pf.step_ends()  # the step read nothing and ended while the worker was busy
        wait_for(lambda: slow["vehicle"].active == 0)
        time.sleep(0.1)
        assert slow["arm"].calls == []  # not computed for a step that is over


class ConnectableDevice(CountingDevice):
    def connect(self) -> None:
        pass

    def safe_stop(self) -> None:
        pass

    def disconnect(self) -> None:
        pass


def _real_backend(prefetch: bool):  # noqa: ANN202
    from hal.drivers.backend import RealBackend
    from hal.drivers.realtime import MonotonicClock
    from hal.interfaces import DeviceSet

    devs = DeviceSet(vehicle=ConnectableDevice("vehicle"), arm=ConnectableDevice("arm"))
    backend = RealBackend(MonotonicClock(), devs)
    backend.health_prefetch = prefetch
    return backend, devs


def test_the_real_backend_prefetches_for_the_step_after_the_request() -> None:
    backend, devs = _real_backend(True)
    backend.open()
    try:
        backend.advance(0.01)
        backend.prefetch_health()  # the loop: the next step is a tree step
        backend.advance(0.05)  # the worker computes while the backend sleeps
        assert devs.arm.health().detail == "arm call 1" and devs.arm.calls == ["health-prefetch"]
        assert backend.health_served == {"prefetched": 1, "on_loop": 0, "left_to_step": 0}
    finally:
        backend.close()
    assert "health" not in vars(devs.arm)  # the driver's own method back
    assert backend.health_served["prefetched"] == 1  # still there for the run's result


def test_maris_run_no_health_prefetch_keeps_every_poll_on_the_loop_thread() -> None:
    backend, devs = _real_backend(False)  # what `maris run --no-health-prefetch` sets before open()
    backend.open()
    try:
        backend.prefetch_health()
        backend.advance(0.02)
        devs.arm.health()
        assert devs.arm.calls == ["MainThread"] and backend.health_served is None
        assert not any(t.name == "health-prefetch" for t in threading.enumerate())
    finally:
        backend.close()


def test_the_work_starts_when_the_loop_hands_over_to_the_pacer_not_at_the_request(devices) -> None:  # noqa: ANN001
    with prefetching(devices, clock=lambda: 0.0) as pf:
        pf.request()  # the loop still finishes its step (log, record): the tick it will sleep for is not known yet
        time.sleep(0.1)
        assert all(d.calls == [] for d in devices.values())
        pf.step_ends(next_tick=0.01)
        wait_for(lambda: all(d.calls == ["health-prefetch"] for d in devices.values()))
