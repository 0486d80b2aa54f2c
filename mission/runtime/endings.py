"""How a supervised run ends: breaches handled as the fault table says, the
tree's end, the abort path (whole, cut short, or skipped), the safe stop and the
settle period. See the supervisor's module docstring and ``docs/faults.md``.

:class:`Endings` decides; :class:`SafeStop` stops every device and keeps the
clock going with zero commands while the vehicle comes to rest.
"""

from __future__ import annotations

import traceback

from py_trees.common import Status

from hal.interfaces import Clock
from mission.runtime.actuation import Actuation
from mission.runtime.context import EventSink, RuntimeContext
from mission.runtime.lifecycle import Lifecycle
from mission.runtime.result import SupervisorOptions
from mission.runtime.safety import INTERRUPTING, Breach, worst
from mission.runtime.samples import LogSamples
from mission.runtime.steps import BaseSteps
from mission.runtime.trees import LeafError, TreeRunner


class SafeStop:
    """The end of all motion: controller stopped, zero commands, ``safe_stop()`` on
    every device, then ``settle_s`` of zero commands, logged at the log rates."""

    def __init__(self, act: Actuation, clock: Clock, steps: BaseSteps, samples: LogSamples, settle_s: float) -> None:
        self.act = act
        self.clock = clock
        self.steps = steps
        self.samples = samples
        self.settle_s = settle_s

    def stop_all(self) -> None:
        self.act.safe_stop_all()

    def settle(self) -> None:
        """Keep the clock going with zero commands so the vehicle comes to rest."""
        clock, steps, samples = self.clock, self.steps, self.samples
        devices = samples.devices
        end = clock.now() + self.settle_s
        while clock.now() < end - 1e-9:
            self.act.zero()
            if steps.due("truth_log"):
                samples.truth.sample(clock.now())
            if samples.rec.active and steps.due("device_log"):
                samples.devices_log(clock.now(), devices.vehicle.navigation(), devices.arm.joint_state())
            if samples.viz.active and steps.due("tf_log"):
                samples.frames(clock.now(), devices.vehicle.navigation(), devices.arm.joint_state())
            steps.advance()


class Endings:
    """Breaches, the trees' ends and the operator's stops turned into the run's end.

    ``failure_cause``: the first cause of a run that does not succeed (set here,
    and by the supervisor for preflight refusals and software errors)."""

    def __init__(
        self,
        lifecycle: Lifecycle,
        events: EventSink,
        ctx: RuntimeContext,
        trees: TreeRunner,
        safe_stop: SafeStop,
        options: SupervisorOptions,
    ) -> None:
        self.lifecycle = lifecycle
        self.events = events
        self.ctx = ctx
        self.clock: Clock = ctx.clock
        self.trees = trees
        self.safe_stop = safe_stop
        self.options = options
        self.failure_cause: str | None = None
        #: ``(kind, source)`` of the breaches reported and not cleared since.
        self.active_breaches: set[tuple[str, str]] = set()
        self._fail_after_abort = False
        self._abort_started = 0.0
        self._abort_deadline = float("inf")

    # ------------------------------------------------------------- breaches
    def handle_breaches(self, breaches: list[Breach], *, complete: bool = True) -> None:
        """Report new breaches once (until they clear) and end the run as the fault table
        says (see the supervisor's module docstring). ``complete``: ``breaches`` is the
        monitors' full list for this step (so breaches missing from it have cleared);
        False adds to the active set."""
        current = {(b.kind, b.source) for b in breaches}
        reported: set[tuple[str, str]] = set()
        for b in breaches:
            key = (b.kind, b.source)
            if key not in self.active_breaches and key not in reported:
                reported.add(key)
                level = "fault" if b.ending in INTERRUPTING else "warning"
                self.events.emit(b.kind, b.message, level=level, source=b.source, ending=b.ending)
        self.active_breaches = current if complete else self.active_breaches | current
        top = worst([b for b in breaches if b.ending in INTERRUPTING])
        if top is None:
            return
        state = self.lifecycle.state
        if state in ("running", "paused"):
            self.begin_abort(str(top), ending=top.ending)
        elif state == "aborting" and self.trees.abort_running is not None:
            if top.ending == "stop":
                self.end_abort(f"safe stop: {top}")
            elif top.ending == "abort_short":
                self.shorten_abort(str(top))

    # ------------------------------------------------------------ main tree
    def tick_main(self) -> None:
        """One tick of the main tree; its success ends the run, its failure or a
        leaf's software error runs the abort path."""
        trees = self.trees
        status = trees.tick_main()
        if isinstance(status, LeafError):
            self.events.emit(
                "internal_error",
                f"{status.cause} (in the mission tree at {status.where}); running the abort path",
                level="fault",
                traceback=status.traceback,
            )
            self.begin_abort(status.cause, failed=True)
        elif status == Status.SUCCESS:
            self.events.emit("mission", "mission tree succeeded")
            self.safe_stop.stop_all()
            self.lifecycle.go("succeed", "tree succeeded")
        elif status == Status.FAILURE:
            self.begin_abort(f"mission failed at {trees.name()}", failed=True)

    # ----------------------------------------------------------- abort path
    def begin_abort(self, cause: str, *, failed: bool = False, ending: str = "abort") -> None:
        """Interrupt the tree; run the abort path (``abort``), a shortened one
        (``abort_short``) or none (``stop``)."""
        self.failure_cause = self.failure_cause or cause
        self._fail_after_abort = failed
        if self.lifecycle.state == "aborting":
            return
        trees = self.trees
        if trees.main_running():
            try:
                trees.halt_main()
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
        if ending == "stop" or not trees.has_abort_path:
            self.end_abort(
                "built-in safe stop" if not trees.has_abort_path else f"safe stop without abort path: {cause}"
            )
            return
        if not trees.start_abort():
            self.end_abort("built-in safe stop")
            return
        self.events.emit("abort_path", f"running the mission's abort path ({cause})", level="warning")
        if ending == "abort_short":
            self.shorten_abort(cause)

    def shorten_abort(self, cause: str) -> None:
        """Bound the running abort path to ``short_abort_s`` from now (if that is sooner)."""
        deadline = self.clock.now() + self.options.short_abort_s
        if deadline < self._abort_deadline:
            self._abort_deadline = deadline
            self.events.emit(
                "abort_path", f"abort path cut short to {self.options.short_abort_s:g} s ({cause})", level="warning"
            )

    def tick_abort(self) -> None:
        """One tick of the running abort path; its end, or its deadline, ends the run."""
        status = self.trees.tick_abort()
        if status is None:
            return
        if status in (Status.SUCCESS, Status.FAILURE):
            self.end_abort(f"abort path ended: {status.value}")
        elif self.clock.now() > self._abort_deadline:
            self.trees.halt_abort()
            self.end_abort(f"abort path timed out after {self.clock.now() - self._abort_started:.3g} s")

    def end_abort(self, how: str) -> None:
        """End the abort (or whatever runs): safe stop, settle, the lifecycle's end state."""
        self.trees.drop_abort()
        self.safe_stop.stop_all()
        self.events.emit("abort", how, level="warning")
        self.safe_stop.settle()
        if self.lifecycle.state == "aborting":
            self.lifecycle.go("end_failed" if self._fail_after_abort else "abort_done", how)
        elif self.lifecycle.can("abort"):
            self.lifecycle.go("abort", how)
            self.lifecycle.go("abort_done", how)

    # ------------------------------------------------------------- operator
    def stop_now(self, source: str) -> None:
        """The operator's ``stop_now`` (or a second ``abort``): the safe stop at once."""
        self.failure_cause = self.failure_cause or f"operator stop ({source})"
        self.end_abort("safe stop on operator request")
