"""Simulator ground truth as the supervisor sees it.

A real backend has no truth (``Backend.ground_truth()`` is None) and everything
here does nothing. On the simulator, :class:`TruthTracker` turns new simulator
events (grasp, slip, injected faults) into supervisor events, keeps the closest
tool-to-target distance (m) for the result, and logs ``/ground_truth``.
"""

from __future__ import annotations

import math
from typing import Any

from mission.runtime import telemetry as tm
from mission.runtime.context import EventSink
from mission.runtime.recorder import RunRecorder


class TruthTracker:
    def __init__(self, backend: Any, events: EventSink, rec: RunRecorder) -> None:
        self.backend = backend
        self.events = events
        self.rec = rec
        #: Closest tool-to-target distance seen so far (m), None before any truth.
        self.min_tool_to_target: float | None = None
        self._sim_events_seen = 0
        #: The last truth read (None on real hardware or before the first sample; without a
        #: log, the brief one of ``Backend.truth_brief``).
        self.last: dict | None = None

    def _closer(self, d: float | None) -> None:
        if d is not None and math.isfinite(d):
            self.min_tool_to_target = d if self.min_tool_to_target is None else min(self.min_tool_to_target, d)

    def sample(self, now: float) -> None:
        """Read the truth once (at the truth rate, logged or not; without a log only
        the part read here, ``Backend.truth_brief``)."""
        brief = getattr(self.backend, "truth_brief", None) if self.rec.log is None else None
        truth = brief() if brief is not None else self.backend.ground_truth()
        if truth is None:
            return
        self.last = truth
        sim_events = truth.get("events") or []
        for ev in sim_events[self._sim_events_seen :]:
            fields = {k: v for k, v in ev.items() if k not in ("event", "t")} if isinstance(ev, dict) else {}
            name = ev.get("event", "event") if isinstance(ev, dict) else str(ev)
            extra = {"sim_" + k: v for k, v in fields.items()}
            if name == "arm_below_floor":  # no collisions in the simulator: in the field, this one would hit the bottom
                depth = fields.get("depth_m")
                at = f" (deepest arm point at {depth:.2f} m)" if isinstance(depth, (int, float)) else ""
                self.events.emit(
                    "sim",
                    f"simulator: the arm reached below the floor{at}; the simulator does not model "
                    "collisions: in the field this is a collision",
                    level="warning",
                    summary=True,
                    **extra,
                )
                continue
            self.events.emit("sim", f"simulator: {name}", **extra)
        self._sim_events_seen = len(sim_events)
        if self.rec.log is None:  # no message to log: only the distance (as truth_message() gives it)
            d = truth.get("tool_to_target_m")
            self._closer(None if d is None else float(d))
            return
        msg = tm.truth_message(truth)
        self._closer(msg.get("tool_to_target_m"))
        self.rec.truth(now, msg)

    def final(self) -> dict:
        """The truth message at the end of the run ({} on real backends)."""
        truth = self.backend.ground_truth()
        msg = tm.truth_message(truth) if truth is not None else {}
        self._closer(msg.get("tool_to_target_m"))
        return msg
