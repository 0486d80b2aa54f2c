"""Wall-clock time for real-device backends.

:class:`MonotonicClock` is the one shared clock of a real backend: seconds since
the backend was built, from ``time.monotonic`` (never jumps with NTP).
:class:`TickPacer` makes ``advance(dt)`` sleep to the next tick instead of
sleeping ``dt`` after whatever the tick cost, so the loop rate does not drift.
:func:`rate_of` turns arrival times into a message rate for health reports.

:data:`STEP_GATE` (a :class:`StepGate`) keeps the drivers' reader and service
threads off the interpreter while the control loop's step runs. Every thread
of the process shares one interpreter lock (GIL); the loop lets go of it during
a step (a file write, a system call, Python's switch interval), and a reader
thread woken by a frame would then take it and keep it, frame after frame,
until it blocks: the loop would wait for it, up to the switch interval (5 ms by
default) at a time. (The KCL's compiled kernels keep the lock while they run,
for the same reason: :func:`kcl.jit.njit`.) The pacer closes the gate :data:`GATE_LEAD` s before each tick and the loop
opens it when it hands over to the pacer; a reader calls
:meth:`StepGate.wait` after its data arrived and before decoding it (holding
none of its locks), and so decodes it right after the step instead of
during it. The wait is bounded: :data:`GATE_MAX_HOLD` s after the gate closed
it counts as open (a long step, or a loop blocked on a device, never starves
a reader), and it is open whenever no paced loop runs.
"""

from __future__ import annotations

import threading
import time
from array import array
from collections.abc import Callable
from typing import Any, Protocol

import numpy as np


class _Clock(Protocol):
    def now(self) -> float: ...


class MonotonicClock:
    """Seconds since construction, monotonic wall time (implements hal.interfaces.Clock)."""

    def __init__(self) -> None:
        self._t0 = time.monotonic()

    def now(self) -> float:
        return time.monotonic() - self._t0


#: Time (s) before each tick at which the pacer closes :data:`STEP_GATE`, so the readers
#: finish what they are decoding before the step starts instead of during it.
GATE_LEAD = 0.0005
#: Longest time (s) :data:`STEP_GATE` holds the readers back after it closed.
GATE_MAX_HOLD = 0.004


class StepGate:
    """Holds driver threads back while the control loop's step runs (see the module docstring).

    The loop thread calls :meth:`close` at the start of its step (the pacer does it) and
    :meth:`open` when the step is done; any other thread calls :meth:`wait` before it
    decodes new data, holding no lock. Thread-safe; the wait never exceeds ``max_hold``
    s after the gate closed."""

    def __init__(self, max_hold: float = GATE_MAX_HOLD) -> None:
        self.max_hold = max_hold
        self._lock = threading.Lock()
        self._closed_at: float | None = None  # time.monotonic() of the close, None while open
        #: Waits that actually held a thread back (for diagnostics).
        self.holds = 0

    @property
    def closed(self) -> bool:
        return self._closed_at is not None

    def close(self) -> None:
        """The step starts (loop thread only). Does nothing if already closed."""
        if self._closed_at is None:
            self._lock.acquire()
            self._closed_at = time.monotonic()

    def open(self) -> None:
        """The step is done (loop thread only): every waiting thread goes on."""
        if self._closed_at is not None:
            self._closed_at = None
            self._lock.release()

    def wait(self) -> None:
        """Return when the gate is open, or ``max_hold`` s after it closed (reader threads)."""
        closed_at = self._closed_at
        if closed_at is None:
            return
        remaining = closed_at + self.max_hold - time.monotonic()
        if remaining > 0.0:
            self.holds += 1
            if self._lock.acquire(timeout=remaining):
                self._lock.release()


#: The gate of this process's control loop (one paced loop per process).
STEP_GATE = StepGate()


#: How many missed ticks :class:`TickPacer` keeps the time of.
MAX_LATE_EVENTS = 2000


class TickPacer:
    """Sleeps so that successive ``advance(dt)`` calls land on a fixed grid.

    If the caller falls more than one tick behind, the grid is re-anchored to now
    (no burst of zero-length ticks to catch up). ``overruns`` counts those;
    ``missed`` counts every tick the caller reached late (its step, wake-up
    delay included, took longer than the period), and each wake-up's lateness
    (s after its tick) is kept for :meth:`timing`.
    """

    def __init__(
        self,
        clock: _Clock,
        sleep: Callable[[float], None] = time.sleep,
        gate: StepGate | None = None,
        gate_lead: float = GATE_LEAD,
    ) -> None:
        self.clock = clock
        self._sleep = sleep
        #: Closed from ``gate_lead`` s before each tick until the next :meth:`advance` (None: no gate).
        self.gate = gate
        self._gate_lead = gate_lead
        self._next: float | None = None
        self.overruns = 0
        self.missed = 0
        #: Per tick: lateness (s after its grid time) when the sleep ended, or when the
        #: caller arrived if it arrived after the tick; and whether it arrived late
        #: (1; 2: more than a period late, an overrun).
        self.late = array("d")
        self.late_arrival = array("b")
        #: Per missed tick (the first MAX_LATE_EVENTS): ``(tick index, time.perf_counter() on
        #: arrival, s late)``: when, on the system's monotonic clock, to set beside other
        #: processes' stalls (benchmarks/field_loop.py).
        self.late_events: list[tuple[int, float, float]] = []

    def advance(self, dt: float) -> None:
        """Wait until ``dt`` s after the previous tick (s, > 0). With a gate: opens it
        (the step is done), closes it again ``gate_lead`` s before the tick."""
        gate = self.gate
        if gate is not None:
            gate.open()
        now = self.clock.now()
        target = (now if self._next is None else self._next) + dt
        behind = now - target
        if self._next is not None and behind >= 0:
            self.missed += 1
            if len(self.late_events) < MAX_LATE_EVENTS:
                self.late_events.append((len(self.late), time.perf_counter(), behind))
            self.late.append(behind)
            self.late_arrival.append(1 if behind <= dt else 2)
            if behind > dt:
                self.overruns += 1
                target = now
            if gate is not None:
                gate.close()
        else:
            if gate is not None:
                lead = target - now - self._gate_lead
                if lead > 0.0:
                    self._sleep(lead)
                gate.close()
                now = self.clock.now()
            if target > now:
                self._sleep(target - now)
            self.late.append(self.clock.now() - target)
            self.late_arrival.append(0)
        self._next = target

    @property
    def ticks(self) -> int:
        """Ticks so far (calls of :meth:`advance`)."""
        return len(self.late)

    def timing(self, since: int = 0) -> dict[str, Any]:
        """Wall-clock figures of the ticks from tick index ``since`` on: ``ticks``,
        ``missed`` (the caller arrived after the tick's time: its step, wake-up delay
        included, took longer than the period), ``overruns`` (of those, more than a
        period behind: the grid re-anchored), lateness percentiles ``late_p50_s`` /
        ``late_p99_s`` / ``late_max_s`` (s after the tick: wake-up delay, or arrival),
        ``late_events``: ``[perf_counter s, s late]`` of the missed ticks (the first
        :data:`MAX_LATE_EVENTS`)."""

        late = np.frombuffer(self.late, dtype=float)[since:]
        flags = np.frombuffer(self.late_arrival, dtype=np.int8)[since:]
        out: dict[str, Any] = {
            "ticks": int(late.size),
            "missed": int(np.count_nonzero(flags)),
            "overruns": int(np.count_nonzero(flags == 2)),
            "late_events": [[at, late_s] for i, at, late_s in self.late_events if i >= since],
        }
        if late.size:
            p50, p99 = np.percentile(late, (50.0, 99.0)).tolist()
            out.update(late_p50_s=p50, late_p99_s=p99, late_max_s=float(late.max()))
        return out

    @property
    def last_tick(self) -> float | None:
        """Clock time (s) of the grid point the last :meth:`advance` waited for."""
        return self._next


def rate_of(times: list[float]) -> float:
    """Mean rate (Hz) of a sorted list of arrival times (s); 0 with fewer than two."""
    if len(times) < 2 or times[-1] <= times[0]:
        return 0.0
    return round((len(times) - 1) / (times[-1] - times[0]), 1)
