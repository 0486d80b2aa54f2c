"""How a supervised run ends: breaches handled as the fault table says, the
abort path (whole, cut short, or skipped), the safe stop and the settle period.
A mixin of :class:`mission.runtime.supervisor.Supervisor` (it uses the
supervisor's lifecycle, trees, events, actuation and options); see the
supervisor's module docstring and ``docs/faults.md``.
"""

from __future__ import annotations

import traceback
from typing import Any

from mission.runtime.safety import INTERRUPTING, Breach, worst


class EndingsMixin:
    """Breach handling and abort endings of the supervisor."""

    lifecycle: Any
    options: Any
    events: Any

    def _handle_breaches(self, breaches: list[Breach], *, complete: bool = True) -> None:
        """Report new breaches once (until they clear) and end the run as the fault table
        says (see the module docstring). ``complete``: ``breaches`` is the monitors' full
        list for this step (so breaches missing from it have cleared); False adds to the
        active set."""
        current = {(b.kind, b.source) for b in breaches}
        reported: set[tuple[str, str]] = set()
        for b in breaches:
            key = (b.kind, b.source)
            if key not in self._active_breaches and key not in reported:
                reported.add(key)
                level = "fault" if b.ending in INTERRUPTING else "warning"
                self.events.emit(b.kind, b.message, level=level, source=b.source, ending=b.ending)
        self._active_breaches = current if complete else self._active_breaches | current
        top = worst([b for b in breaches if b.ending in INTERRUPTING])
        if top is None:
            return
        state = self.lifecycle.state
        if state in ("running", "paused"):
            self._begin_abort(str(top), ending=top.ending)
        elif state == "aborting" and self.abort_tree is not None:
            if top.ending == "stop":
                self._end_abort(f"safe stop: {top}")
            elif top.ending == "abort_short":
                self._shorten_abort(str(top))

    # ---------------------------------------------------------------- trees
    def _begin_abort(self, cause: str, *, failed: bool = False, ending: str = "abort") -> None:
        """Interrupt the tree; run the abort path (``abort``), a shortened one
        (``abort_short``) or none (``stop``)."""
        from py_trees.common import Status

        self.failure_cause = self.failure_cause or cause
        self._fail_after_abort = failed
        if self.lifecycle.state == "aborting":
            return
        if self.tree is not None and self.tree.status == Status.RUNNING:
            try:
                self.tree.stop(Status.INVALID)
            except Exception as exc:  # noqa: BLE001 - a leaf failing to halt: motion is stopped below anyway
                self.events.emit(
                    "internal_error",
                    f"halting the mission tree failed: {type(exc).__name__}: {exc}",
                    level="fault",
                    traceback=traceback.format_exc(),
                )
        self.ctx.stop_motion()
        self.lifecycle.go("abort", cause)
        self._abort_started = self.clock.now()
        self._abort_deadline = self._abort_started + self.options.abort_timeout_s
        if ending == "stop" or self.make_abort_tree is None:
            self._end_abort(
                "built-in safe stop" if self.make_abort_tree is None else f"safe stop without abort path: {cause}"
            )
            return
        self.abort_tree = self._abort_root
        if self.abort_tree is None:
            self._end_abort("built-in safe stop")
            return
        self.events.emit("abort_path", f"running the mission's abort path ({cause})", level="warning")
        if ending == "abort_short":
            self._shorten_abort(cause)

    def _shorten_abort(self, cause: str) -> None:
        """Bound the running abort path to ``short_abort_s`` from now (if that is sooner)."""
        deadline = self.clock.now() + self.options.short_abort_s
        if deadline < self._abort_deadline:
            self._abort_deadline = deadline
            self.events.emit(
                "abort_path", f"abort path cut short to {self.options.short_abort_s:g} s ({cause})", level="warning"
            )

    def _tick_abort(self) -> None:
        from py_trees.common import Status

        if self.abort_tree is None:
            return
        self.abort_tree.tick_once()
        self._after_tick(self.abort_tree)
        status = self.abort_tree.status
        if status in (Status.SUCCESS, Status.FAILURE):
            self._end_abort(f"abort path ended: {status.value}")
        elif self.clock.now() > self._abort_deadline:
            self.abort_tree.stop(Status.INVALID)
            self._end_abort(f"abort path timed out after {self.clock.now() - self._abort_started:.3g} s")

    def _end_abort(self, how: str) -> None:
        self.abort_tree = None
        self.act.safe_stop_all()
        self.events.emit("abort", how, level="warning")
        self._settle()
        if self.lifecycle.state == "aborting":
            self.lifecycle.go("end_failed" if self._fail_after_abort else "abort_done", how)
        elif self.lifecycle.can("abort"):
            self.lifecycle.go("abort", how)
            self.lifecycle.go("abort_done", how)

    def _settle(self) -> None:
        """Keep the clock going with zero commands so the vehicle comes to rest."""
        end = self.clock.now() + self.options.settle_s
        while self.clock.now() < end - 1e-9:
            self.act.zero()
            if self.schedule.due("truth_log", self.step):
                self.truth.sample(self.clock.now())
            if self.rec.active and self.schedule.due("device_log", self.step):
                self.rec.devices(
                    self.clock.now(),
                    self.devices,
                    self.devices.vehicle.navigation(),
                    self.devices.arm.joint_state(),
                    self.act.vehicle_cmd,
                    self.act.arm_cmd,
                )
            if self.viz.active and self.schedule.due("tf_log", self.step):
                self._log_frames(self.clock.now(), self.devices.vehicle.navigation(), self.devices.arm.joint_state())
            self.backend.advance(self.dt)
            self.step += 1
