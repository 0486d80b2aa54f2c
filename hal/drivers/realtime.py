"""Wall-clock time for real-device backends.

:class:`MonotonicClock` is the one shared clock of a real backend: seconds since
the backend was built, from ``time.monotonic`` (never jumps with NTP).
:class:`TickPacer` makes ``advance(dt)`` sleep to the next tick instead of
sleeping ``dt`` after whatever the tick cost, so the loop rate does not drift.
:func:`rate_of` turns arrival times into a message rate for health reports.
"""

from __future__ import annotations

import time
from array import array
from typing import Any, Callable, Protocol


class _Clock(Protocol):
    def now(self) -> float: ...


class MonotonicClock:
    """Seconds since construction, monotonic wall time (implements hal.interfaces.Clock)."""

    def __init__(self) -> None:
        self._t0 = time.monotonic()

    def now(self) -> float:
        return time.monotonic() - self._t0


class TickPacer:
    """Sleeps so that successive ``advance(dt)`` calls land on a fixed grid.

    If the caller falls more than one tick behind, the grid is re-anchored to now
    (no burst of zero-length ticks to catch up). ``overruns`` counts those;
    ``missed`` counts every tick the caller reached late (its step, wake-up
    delay included, took longer than the period), and each wake-up's lateness
    (s after its tick) is kept for :meth:`timing`.
    """

    def __init__(self, clock: _Clock, sleep: Callable[[float], None] = time.sleep) -> None:
        self.clock = clock
        self._sleep = sleep
        self._next: float | None = None
        self.overruns = 0
        self.missed = 0
        #: Per tick: lateness (s after its grid time) when the sleep ended, or when the
        #: caller arrived if it arrived after the tick; and whether it arrived late
        #: (1; 2: more than a period late, an overrun).
        self.late = array("d")
        self.late_arrival = array("b")

    def advance(self, dt: float) -> None:
        """Wait until ``dt`` s after the previous tick (s, > 0)."""
        now = self.clock.now()
        target = (now if self._next is None else self._next) + dt
        behind = now - target
        if self._next is not None and behind >= 0:
            self.missed += 1
            self.late.append(behind)
            self.late_arrival.append(1 if behind <= dt else 2)
            if behind > dt:
                self.overruns += 1
                target = now
        else:
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
        ``late_p99_s`` / ``late_max_s`` (s after the tick: wake-up delay, or arrival)."""
        import numpy as np

        late = np.frombuffer(self.late, dtype=float)[since:]
        flags = np.frombuffer(self.late_arrival, dtype=np.int8)[since:]
        out: dict[str, Any] = {"ticks": int(late.size), "missed": int(np.count_nonzero(flags)),
                               "overruns": int(np.count_nonzero(flags == 2))}
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
