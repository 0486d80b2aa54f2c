"""Wall-clock timing of the supervisor loop: per-step work, and in real time the
latency from a sensor reading to the command it causes.

A step's *work* is the wall time (s) from its start to the end of its logging
(device reads, safety, tree, KCL, commands, logging), before the log's periodic
flush, if due (:mod:`mission.runtime.logflush`, timed apart), and the hand-over
to ``backend.advance``: in real time the rest of the base period is spent
waiting for the next tick. :class:`StepTimes` keeps every step's work (8 bytes a step) and
reports percentiles at the end; real backends add their own wake-up figures
(:meth:`hal.drivers.realtime.TickPacer.timing`).

*Latency* (real time only): for each new AHRS attitude reading (``nav.t``) and
each new joint-state reading (``js.t``, the oldest joint's PDO), the time from
its arrival stamp (taken by the driver's reader thread, backend clock) to the
moment the first command computed from it was handed to the drivers
(``act.send`` returned). Readings that arrived before the loop's first step
(:attr:`StepTimes.count_from_t`) are left out: during the preflight and the
engagement (arming confirmed by the vehicle, drives enabled) no command may go
out, so the first command's readings waited for that, not for the loop. The
drivers' own send cadence (the CANopen service thread, the MAVLink setpoint
stream) comes after that and is not included.

*Slowest steps*: the :data:`SLOWEST_KEPT` steps with the longest work, each
with its time split by phase (:data:`STEP_PHASES`) and, in real time, the
loop thread's CPU time over the step (``cpu_s``; much less than ``work_s``
means the step waited: another thread held the interpreter, or the OS ran
something else), to tell what a deadline miss was made of.

These are wall-clock figures: they depend on the machine and its load, never
on the run's inputs, and they are kept out of the deterministic results
(names start with ``wall``).
"""

from __future__ import annotations

import heapq
from array import array
from typing import Any, NamedTuple

import numpy as np


def _percentiles(values: array, prefix: str = "") -> dict[str, Any]:
    """``{n, p50_s, p99_s, p999_s, max_s}`` of ``values`` (s); Nones when empty."""
    if not len(values):
        return {"n": 0, "p50_s": None, "p99_s": None, "p999_s": None, "max_s": None}
    v = np.frombuffer(values, dtype=float)
    p50, p99, p999 = np.percentile(v, (50.0, 99.0, 99.9)).tolist()
    return {"n": int(v.size), "p50_s": p50, "p99_s": p99, "p999_s": p999, "max_s": float(v.max())}


#: The phases of a step's work, in the order of :meth:`StepTimes.note_slow`'s ``phases``:
#: operator requests and device reads, safety checks, tree tick, vehicle KCL, arm KCL,
#: commands handed to the devices, logs and progress.
STEP_PHASES = ("read", "safety", "tree", "kcl_vehicle", "kcl_arm", "send", "log_progress")
#: How many of the slowest steps :class:`StepTimes` keeps.
SLOWEST_KEPT = 50


class SlowStep(NamedTuple):
    """One of the slowest steps; ordered by its work first (the heap of :class:`StepTimes`)."""

    #: Wall time (s) of the step's work.
    work: float
    step: int
    #: Backend time (s) since the run's start.
    t: float
    tree_step: bool
    #: Wall time (s) per phase of :data:`STEP_PHASES`.
    phases: tuple[float, ...]
    #: The loop thread's CPU time (s) over the step, None when not measured.
    cpu: float | None
    #: ``time.perf_counter()`` at the step's start.
    start: float


class StepTimes:
    """Work time (s) of every loop step, in order, reading-to-command latencies (s)
    and the slowest steps with their phases."""

    def __init__(self) -> None:
        self.work = array("d")
        #: min-heap of the slowest steps (the fastest of them first)
        self._slowest: list[SlowStep] = []
        self.nav_latency = array("d")
        self.joint_latency = array("d")
        #: arrival stamps (backend clock, s) of the readings of ``nav_latency`` / ``joint_latency``
        self.nav_read_t = array("d")
        self.joint_read_t = array("d")
        self._nav_t = float("nan")
        self._js_t = float("nan")
        #: Readings that arrived before this time (backend clock, s) are not counted: set at
        #: the loop's first step, after the engagement (no command may go out before it, so a
        #: reading of the preflight or the engagement waits for it by design).
        self.count_from_t = float("-inf")

    def command_sent(self, t_sent: float, nav_t: float, js_t: float) -> None:
        """A command computed from readings stamped ``nav_t`` / ``js_t`` was handed to
        the drivers at ``t_sent`` (backend clock, s): counts each reading once, at the
        first command it caused (a reading reused by later steps is not counted again)."""
        if nav_t != self._nav_t and nav_t == nav_t:
            self._nav_t = nav_t
            if nav_t >= self.count_from_t:
                self.nav_latency.append(t_sent - nav_t)
                self.nav_read_t.append(nav_t)
        if js_t != self._js_t and js_t == js_t:
            self._js_t = js_t
            if js_t >= self.count_from_t:
                self.joint_latency.append(t_sent - js_t)
                self.joint_read_t.append(js_t)

    def note_slow(
        self,
        work: float,
        step: int,
        t: float,
        tree_step: bool,
        phases: tuple[float, ...],
        cpu: float | None = None,
        start: float = float("nan"),
    ) -> float:
        """Keep step ``step`` (backend time ``t``, s) among the slowest if its ``work``
        (s) is; ``phases``: wall time (s) per :data:`STEP_PHASES`; ``cpu``: the loop
        thread's CPU time over the step (s), None when not measured; ``start``: its
        ``time.perf_counter()`` at the start (the system's monotonic clock: other
        processes' stalls can be put beside it). Returns the work a later step must
        exceed to be kept (the caller skips this call below it)."""
        entry = SlowStep(work, step, t, tree_step, phases, cpu, start)
        heap = self._slowest
        if len(heap) < SLOWEST_KEPT:
            heapq.heappush(heap, entry)
            return heap[0].work if len(heap) == SLOWEST_KEPT else 0.0
        heapq.heappushpop(heap, entry)
        return heap[0].work

    def slowest(self) -> list[dict[str, Any]]:
        """The kept slowest steps, slowest first: ``{step, t, tree_step, work_s, cpu_s,
        start_s, phases_s: {phase: s}}`` (``start_s``: ``time.perf_counter()``)."""
        out = []
        for s in sorted(self._slowest, reverse=True):
            out.append(
                {
                    "step": s.step,
                    "t": s.t,
                    "tree_step": s.tree_step,
                    "work_s": s.work,
                    "cpu_s": s.cpu,
                    "start_s": s.start,
                    "phases_s": dict(zip(STEP_PHASES, s.phases)),
                }
            )
        return out

    def summary(self, period_s: float) -> dict[str, Any]:
        """``{steps, p50_s, p99_s, p999_s, max_s, over_period}``: percentiles of the
        work per step and how many steps worked longer than ``period_s``."""
        out = _percentiles(self.work)
        out["steps"] = out.pop("n")
        w = np.frombuffer(self.work, dtype=float) if len(self.work) else np.zeros(0)
        out["over_period"] = int(np.count_nonzero(w > period_s))
        return out

    def latency_summary(self, t0: float = 0.0) -> dict[str, Any]:
        """``{"ahrs": {...}, "joints": {...}}``: percentiles (s) of reading-to-command
        latency, and ``max_at_s``: when the reading of the largest one arrived (s after
        ``t0``, the run's start on the backend clock; None without readings)."""
        out = {}
        for name, lat, read_t in (
            ("ahrs", self.nav_latency, self.nav_read_t),
            ("joints", self.joint_latency, self.joint_read_t),
        ):
            out[name] = d = _percentiles(lat)
            d["max_at_s"] = None
            if len(lat):
                d["max_at_s"] = read_t[int(np.argmax(np.frombuffer(lat, dtype=float)))] - t0
        return out
