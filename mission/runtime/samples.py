"""The periodic samples of a run's log that more than one part of the supervisor
takes: the device readings with the commands last sent, and the 3D view.

The loop takes them at their schedule's rates, the settle period after a stop
too, and the run's end once more after the final zero commands (so that the log
ends on them). Without a log every sample does nothing.
"""

from __future__ import annotations

from typing import Any

from hal.interfaces import DeviceSet
from mission.runtime.actuation import Actuation
from mission.runtime.context import EventSink, RuntimeContext
from mission.runtime.recorder import RunRecorder
from mission.runtime.truth import TruthTracker
from mission.runtime.viz import VizRecorder


class LogSamples:
    """Device and 3D-view samples of the run log (times: backend clock, s)."""

    def __init__(
        self,
        rec: RunRecorder,
        viz: VizRecorder,
        truth: TruthTracker,
        ctx: RuntimeContext,
        act: Actuation,
        events: EventSink,
    ) -> None:
        self.rec = rec
        self.viz = viz
        self.truth = truth
        self.ctx = ctx
        self.act = act
        self.events = events
        self.devices: DeviceSet = ctx.devices

    def devices_log(self, now: float, nav: Any, js: Any) -> None:
        """The device readings ``nav``/``js`` and the commands last sent."""
        self.rec.devices(now, self.devices, nav, js, self.act.vehicle_cmd, self.act.arm_cmd)

    def frames(self, now: float, nav: Any, js: Any) -> None:
        """The 3D view: frame tree, named joints, goals (see :mod:`mission.runtime.viz`)."""
        detector = self.devices.detector
        self.viz.frames(
            now,
            nav,
            js,
            self.ctx.controller,
            self.ctx.blackboard,
            detector.latest() if detector is not None else None,
            self.truth.last,
        )

    def final_commands(self) -> None:
        """The devices once more after the final zero commands, so the log ends on them;
        a failure to log is reported as an event, never raised (it must not mask the result)."""
        if not self.rec.active:
            return
        try:
            self.rec.devices(
                self.ctx.clock.now(),
                self.devices,
                self.devices.vehicle.navigation(),
                self.devices.arm.joint_state(),
                self.act.vehicle_cmd,
                self.act.arm_cmd,
            )
        except Exception as exc:  # noqa: BLE001 - logging must not mask the result
            self.events.emit("log", f"final command sample not logged: {exc}", level="warning")
