"""Device health computed between control steps, for the step that reads it.

The supervisor polls every device's ``health()`` at the tree rate (10 Hz), on
the tree step. A real driver's health is a report assembled from its whole
state (link, streams and their rates, per-drive states, the autopilot's
messages), so the poll is a large part of that step's work, and the tree steps
are the slowest ones: they set the loop's p99 step work
(``benchmarks/field_loop.py`` measures it, with ``wall_health_prefetch``).

:class:`HealthPrefetcher` moves that work off the loop thread. At the end of
the step before a tree step the loop calls :meth:`HealthPrefetcher.request`
(through ``Backend.prefetch_health``); when it then hands over to the pacer
(:meth:`HealthPrefetcher.step_ends`, with the next tick's time) a worker
thread computes every device's health while the loop sleeps, device by
device, each after :meth:`hal.drivers.realtime.StepGate.wait` (never during a
step, as the drivers' readers). During the next step, each device's first ``health()``
returns what the worker computed (or raises what it raised); any other call
computes it then (the preflight, ``maris hal check``, a second call
in the same step, a step the request did not precede). A device the worker has
not finished is waited for, one it has not started is computed by the caller
(and skipped by the worker): never two computations of one device at once.
The worker starts no device within ``margin_s`` (2 ms) of the next tick: on a
stalled host it leaves the rest to the step instead of holding the interpreter
when the loop wakes up.

The price: the health the tree step reads is as of the end of the previous
step, up to one base period (10 ms) older than a poll at the step itself;
beside the health timeouts (0.5 s and more) nothing changes. Every reading
(navigation, joints, the gripper's state) is still read on the step itself.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

from hal.drivers.realtime import StepGate


class _Entry:
    """One device's health for one request, served once (stored complete, under the
    device's lock; ``served`` from the start: the loop computed it itself)."""

    __slots__ = ("request", "value", "error", "served")

    def __init__(
        self, request: int, value: Any = None, error: BaseException | None = None, served: bool = False
    ) -> None:
        self.request = request
        self.value = value
        self.error = error
        self.served = served


class HealthPrefetcher:
    """Serves each device's ``health()`` from a worker's computation (module docstring).

    ``devices``: role -> device; :meth:`install` makes each device's ``health``
    attribute the served one (an instance attribute over the driver's method),
    :meth:`close` puts the drivers' own back and stops the worker."""

    def __init__(
        self,
        devices: dict[str, Any],
        gate: StepGate | None = None,
        clock: Callable[[], float] | None = None,
        margin_s: float = 0.002,
    ) -> None:
        """``clock()``: the backend clock (s), the time base of :meth:`step_ends`' next
        tick; the worker starts no device less than ``margin_s`` s before that tick."""
        self._gate = gate
        self._clock = clock
        self.margin_s = margin_s
        self._deadline: float | None = None  # the tick the prefetch is for (clock s)
        self._own: dict[str, Callable[[], Any]] = {role: dev.health for role, dev in devices.items()}
        self._devices = dict(devices)
        self._locks = {role: threading.Lock() for role in devices}
        self._entries: dict[str, _Entry] = {}
        self._request = 0  # the latest request's number (0: none yet)
        self._open_request = 0  # the request whose step runs now (0: none)
        self._pending = 0  # a request made, its step not begun
        self._wake = threading.Event()
        self._stop = False
        self._thread: threading.Thread | None = None
        #: Devices served from the worker / computed by the caller instead (diagnostics).
        self.served = 0
        self.computed_by_caller = 0
        #: Requests the worker left (partly) to the step: the next tick was too close.
        self.left_to_step = 0

    # ------------------------------------------------------------------ lifecycle
    def install(self) -> None:
        """Start the worker and serve the devices' ``health()``. Call before the loop
        starts (``maris run --rt-priority`` moves the threads that exist then below the loop)."""
        if self._thread is not None:
            return
        for role, dev in self._devices.items():
            dev.health = self._served(role)
        self._thread = threading.Thread(target=self._work, name="health-prefetch", daemon=True)
        self._thread.start()

    def close(self) -> None:
        """Stop the worker and give every device its own ``health()`` back. Idempotent."""
        self._stop = True
        self._wake.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=1.0)
        self._thread = None
        for dev in self._devices.values():
            if "health" in vars(dev):
                del dev.health

    # ------------------------------------------------------------------ loop thread
    def request(self) -> None:
        """The next step polls health: have it computed before that step (loop thread,
        at the end of a step; the work starts at :meth:`step_ends`)."""
        self._request += 1
        self._pending = self._request

    def step_ends(self, next_tick: float | None = None) -> None:
        """The step is over (the backend's ``advance`` was called; ``next_tick``: the clock
        time, s, of the tick it sleeps for): what was prefetched for this step is served
        no more, and a pending request is worked on now."""
        self._open_request = 0
        if self._pending:
            self._deadline = next_tick
            self._wake.set()

    def step_begins(self) -> None:
        """A new step starts (the backend's ``advance`` returned): the last request's
        results serve this step only."""
        self._open_request, self._pending = self._pending, 0

    def _served(self, role: str) -> Callable[[], Any]:
        own, lock = self._own[role], self._locks[role]

        def health() -> Any:
            req = self._open_request
            if req:
                with lock:  # waits for the worker if it is computing this device now
                    entry = self._entries.get(role)
                    if entry is None or entry.request != req:
                        self._entries[role] = _Entry(req, served=True)  # the worker skips it
                    elif not entry.served:
                        entry.served = True
                        self.served += 1
                        if entry.error is not None:
                            raise entry.error
                        return entry.value
                    self.computed_by_caller += 1
                    return own()
            return own()

        return health

    # ------------------------------------------------------------------ worker
    def _useful(self, req: int) -> bool:
        """Whether request ``req``'s results can still be served (its step is ahead or running)."""
        return not self._stop and (self._pending == req or self._open_request == req)

    def _work(self) -> None:
        while True:
            self._wake.wait()
            self._wake.clear()
            if self._stop:
                return
            req = self._request
            for role, own in self._own.items():
                if not self._useful(req):
                    break  # stopped, a newer request (woken again), or its step is over
                if self._gate is not None:
                    self._gate.wait()
                    if not self._useful(req):
                        break
                deadline = self._deadline
                if self._clock is not None and deadline is not None and deadline - self._clock() < self.margin_s:
                    self.left_to_step += 1
                    break  # too close to the tick: the step computes the rest itself
                with self._locks[role]:
                    entry = self._entries.get(role)
                    if entry is not None and entry.request == req:
                        continue  # the loop took it already
                    try:
                        self._entries[role] = _Entry(req, value=own())
                    except Exception as exc:  # noqa: BLE001 - handed to the caller, who raises it
                        self._entries[role] = _Entry(req, error=exc)
